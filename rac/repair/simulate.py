"""The repair domain's semantics in Python: apply a plan to a problem's state.

This mirrors ``repair_domain.pddl.j2`` action by action; the tests check the
two agree by validating the same plans with unified-planning.  ``racc
scenario`` prints the state this computes after the plan.
"""

from __future__ import annotations

from dataclasses import dataclass

from rac.repair.planner import Step
from rac.repair.problem import RepairProblem
from rac.repair.system import Kind, RepairSystem


@dataclass(frozen=True, slots=True)
class State:
    running: frozenset[str]
    on: frozenset[str]
    bad: frozenset[str]  # the domain keeps good and bad exclusive: good is the rest


class InapplicableStep(ValueError):
    """A plan step whose action, arguments or precondition do not fit the state."""


@dataclass(frozen=True, slots=True)
class _Index:
    """The system's lookups, built once per plan rather than once per step."""

    kinds: dict[str, Kind]
    drivers: dict[str, frozenset[str]]  # device -> the nodes driving it
    devices: dict[str, frozenset[str]]  # node -> the devices it drives

    @staticmethod
    def of(system: RepairSystem) -> _Index:
        drivers: dict[str, set[str]] = {}
        devices: dict[str, set[str]] = {}
        for n, d in system.drives:
            drivers.setdefault(d, set()).add(n)
            devices.setdefault(n, set()).add(d)
        return _Index(
            dict(system.components),
            {d: frozenset(ns) for d, ns in drivers.items()},
            {n: frozenset(ds) for n, ds in devices.items()},
        )

    def target(self, step: Step, kind: Kind) -> str:
        if len(step) != 2:
            raise InapplicableStep(f"{step[0]} takes one argument: {step}")
        if self.kinds.get(step[1]) is not kind:
            raise InapplicableStep(f"{step[0]}: {step[1]} is not a {kind.value}")
        return step[1]


def initial_state(problem: RepairProblem) -> State:
    return State(frozenset(problem.running), frozenset(problem.on), frozenset(problem.bad))


class _Mutable:
    """A state being changed step by step: sets changed in place, so a plan of n steps on
    n components costs O(n), not O(n²) as new frozensets per step did."""

    def __init__(self, state: State) -> None:
        self.running, self.on, self.bad = set(state.running), set(state.on), set(state.bad)

    def frozen(self) -> State:
        return State(frozenset(self.running), frozenset(self.on), frozenset(self.bad))


def _apply(index: _Index, state: _Mutable, step: Step) -> None:
    action = step[0] if step else ""
    if action == "stop_node":
        n = index.target(step, Kind.NODE)
        if n not in state.bad or n not in state.running:
            raise InapplicableStep(f"stop_node({n}) needs {n} bad and running")
        state.running.discard(n)
    elif action == "start_node":
        n = index.target(step, Kind.NODE)
        if n in state.running or not index.devices.get(n, frozenset()) <= state.on:
            raise InapplicableStep(f"start_node({n}) needs {n} stopped and its devices on")
        state.running.add(n)
        state.bad.discard(n)
    elif action == "shutdown":
        d = index.target(step, Kind.DEVICE)
        if d not in state.bad or d not in state.on:
            raise InapplicableStep(f"shutdown({d}) needs {d} bad and on")
        state.on.discard(d)
        state.bad |= index.drivers.get(d, frozenset())
    elif action == "power_up":
        d = index.target(step, Kind.DEVICE)
        if d in state.on:
            raise InapplicableStep(f"power_up({d}) needs {d} off")
        state.on.add(d)
        state.bad.discard(d)
        state.bad |= index.drivers.get(d, frozenset())
    else:
        raise InapplicableStep(f"unknown repair action: {action or step}")


def apply_step(system: RepairSystem, state: State, step: Step) -> State:
    """The successor state; raises InapplicableStep when a precondition fails."""
    changing = _Mutable(state)
    _apply(_Index.of(system), changing, step)
    return changing.frozen()


def simulate(problem: RepairProblem, plan: tuple[Step, ...]) -> State:
    index = _Index.of(problem.system)
    state = _Mutable(initial_state(problem))
    for step in plan:
        _apply(index, state, step)
    return state.frozen()


def check_plan(problem: RepairProblem, plan: tuple[Step, ...]) -> State:
    """Simulate and require the goal (every component good); the final state."""
    state = simulate(problem, plan)
    if state.bad:
        raise InapplicableStep(f"still bad after the plan: {', '.join(sorted(state.bad))}")
    return state
