"""The dissertation's two repair experiments (§10.1.1.1, §10.1.1.2) as observation sets.

A scenario names the components that are faulty; the observations are what
the observers would then report: every observable atom (``props``) holds
exactly when the clauses derive it with the faulty components abnormal (AB)
and the others normal (NAB).  A switchable device that is off and a node that
is stopped are abnormal; a driver whose device went off still runs.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import Any

from rac.diagnosis import Literal, Theory, predict
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.ir import Model
from rac.logic import mangle
from rac.repair.engine import RepairResult, prepare, repair_system, solve
from rac.repair.errors import NoRepairPlan
from rac.repair.order import dataflow_order
from rac.repair.planner import DEFAULT_TIMEOUT_S
from rac.repair.simulate import State
from rac.repair.system import Kind, RepairSystem

SCENARIOS = ("power-up", "device-shutdown")


@dataclass(frozen=True, slots=True)
class Scenario:
    name: str
    faulty: tuple[str, ...]  # the components the scenario breaks
    device: str | None = None  # device-shutdown: the device that goes off


def observations(theory: Theory, faulty: Iterable[str]) -> tuple[Literal, ...]:
    """Θ as the observers would report it, in ``props`` order (``racc simulate``'s prediction).

    A model server file without ``props`` observes every rule head, as ``racc simulate`` does.
    """
    return predict(theory, tuple(faulty))


def power_up(system: RepairSystem) -> Scenario:
    """§10.1.1.1: every switchable device off, every node stopped."""
    faulty = system.of_kind(Kind.NODE) + system.of_kind(Kind.DEVICE)
    return Scenario("power-up", tuple(sorted(faulty)))


def default_device(system: RepairSystem, model: Model | None) -> str | None:
    """The first switchable device: in declaration order for a RAM, by name otherwise."""
    devices = system.of_kind(Kind.DEVICE)
    if model is not None:
        declared = [mangle(h.name.value) for h in model.hardware if h.switchable]
        devices = tuple(d for d in declared if d in devices)
    return devices[0] if devices else None


def device_shutdown(system: RepairSystem, model: Model | None, device: str | None) -> Scenario:
    """§10.1.1.2: one device goes off while everything else runs."""
    if device is None:
        device = default_device(system, model)
        if device is None:
            raise RacError(
                [
                    Diagnostic(
                        "RAC076",
                        "the model has no switchable device to shut down",
                        hint="name a hardware component with --device",
                    )
                ]
            )
    name = mangle(device)
    hardware = system.of_kind(Kind.DEVICE) + system.of_kind(Kind.HARDWARE)
    fixed = model is not None and any(
        mangle(h.name.value) == name and not h.switchable for h in model.hardware
    )
    if name not in hardware and fixed:
        switchable = sorted(system.of_kind(Kind.DEVICE))
        raise RacError(
            [
                Diagnostic(
                    "RAC076",
                    f"'{device}' is not switchable: the board cannot shut it down",
                    hint=f"switchable devices: {', '.join(switchable) or 'none'}",
                )
            ]
        )
    if name not in hardware:
        raise RacError(
            [
                Diagnostic(
                    "RAC076",
                    f"'{device}' is not a hardware component of the model",
                    hint=did_you_mean(name, hardware)
                    or f"hardware components: {', '.join(sorted(hardware)) or 'none'}",
                )
            ]
        )
    return Scenario("device-shutdown", (name,), name)


@dataclass(frozen=True, slots=True)
class ScenarioResult:
    scenario: Scenario
    repair: RepairResult

    def to_json(self) -> dict[str, Any]:
        system = self.repair.prepared.problem.system
        final = self.repair.final
        return {
            "scenario": self.scenario.name,
            "device": self.scenario.device,
            "observations": [str(o) for o in self.repair.prepared.observations],
            **self.repair.to_json(),
            "state": state_json(system, final),
        }


def state_json(system: RepairSystem, state: State) -> dict[str, dict[str, Any]]:
    """Per component: kind, running (nodes) or on (devices), and good."""
    out: dict[str, dict[str, Any]] = {}
    for comp, kind in system.components:
        entry: dict[str, Any] = {"kind": kind.value}
        if kind is Kind.NODE:
            entry["running"] = comp in state.running
        elif kind is Kind.DEVICE:
            entry["on"] = comp in state.on
        entry["good"] = comp not in state.bad
        out[comp] = entry
    return out


def make_scenario(theory: Theory, name: str, device: str | None = None) -> Scenario:
    system = repair_system(theory)
    if name == "power-up":
        return power_up(system)
    if name == "device-shutdown":
        return device_shutdown(system, theory.model, device)
    raise ValueError(f"unknown scenario {name!r}; choose from {', '.join(SCENARIOS)}")


def run_scenario(
    theory: Theory,
    robot: str,
    name: str,
    device: str | None = None,
    timeout_s: float = DEFAULT_TIMEOUT_S,
) -> ScenarioResult:
    """Break the robot as the scenario says, diagnose what the observers see, plan the repair."""
    scenario = make_scenario(theory, name, device)
    if scenario.device is not None and repair_system(theory).unrepairable((scenario.device,)):
        # The experiment power-cycles the device; one off the board cannot come back.
        raise NoRepairPlan(
            "RAC071",
            f"no repair action can make {scenario.device} good: it is hardware that is not "
            "switchable, so it cannot be powered up again",
            hint="pick a switchable device with --device",
        )
    theta = observations(theory, scenario.faulty)
    prepared = prepare(theory, theta, robot)
    result = solve(prepared, timeout_s)
    if name == "power-up" and theory.model is not None:
        plan = dataflow_order(result.plan, prepared.problem.system, theory.model)
        result = replace(result, plan=plan)
    return ScenarioResult(scenario, result)
