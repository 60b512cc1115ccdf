"""The observer host's, the diagnosis and the repair nodes' loops (rac.runtime.nodes) on a
bus without ROS: what they subscribe to, what they publish, and that they stop with the
bus."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

from rac.load.files import load_model
from rac.load.theory import load_theory
from rac.logic import Atom
from rac.observe import Verdict
from rac.passes.observers import DIAGNOSTICS_TOPIC, ObserverSpec
from rac.pipeline import compile_model
from rac.runtime.diagnoser import Diagnoser
from rac.runtime.host import ObserverHost
from rac.runtime.nodes import RepairJob, run_engine_node, run_observer_node, run_repair_node
from rac.runtime.procs import ProcessProbe
from rac.runtime.repairer import Mode, Settings
from rac.runtime.routing import Agent
from rac.runtime.status import (
    DIAGNOSIS,
    OBSERVATIONS,
    REPAIR_LOG,
    REPAIR_PLAN,
    Row,
    literal_row,
    row_diagnosis,
)
from rac.targets import EmitOptions, emit_all

ROOT = Path(__file__).resolve().parents[2]
CRASH = Verdict(0, Atom("running", ("jaguar_node",)), False)
TIME_LIMIT_S = 20.0


class FakeBus:
    """Records publications and subscriptions; stops when ``done`` holds or time is up."""

    def __init__(self, done: Callable[[FakeBus], bool]) -> None:
        self.done = done
        self.published: dict[str, list[list[Row]]] = {}
        self.latched: dict[str, bool] = {}
        self.rows_callbacks: dict[str, Callable[[list[Row]], None]] = {}
        self.text_callbacks: dict[str, Callable[[str], None]] = {}
        self.logged: list[tuple[int, str]] = []
        self.ticks = 0
        self.deadline = time.monotonic() + TIME_LIMIT_S

    @property
    def name(self) -> str:
        return "racc_test"

    @property
    def ok(self) -> bool:
        self.ticks += 1
        if (
            self.ticks == 2 and OBSERVATIONS in self.rows_callbacks
        ):  # the node is set up and in its loop: the robot speaks
            self.rows_callbacks[OBSERVATIONS]([literal_row(CRASH, "jaguar_node_pobs")])
        return not self.done(self) and time.monotonic() < self.deadline

    def log(self, level: int, text: str) -> None:
        self.logged.append((level, text))

    def rows_publisher(
        self, topic: str, depth: int, latched: bool = False
    ) -> Callable[[Sequence[Row]], None]:
        self.latched[topic] = latched
        sent = self.published.setdefault(topic, [])
        return lambda rows: sent.append(list(rows))

    def on_rows(
        self, topic: str, callback: Callable[[list[Row]], None], depth: int, latched: bool = False
    ) -> None:
        self.rows_callbacks[topic] = callback

    def on_text(self, topic: str, callback: Callable[[str], None], depth: int) -> None:
        self.text_callbacks[topic] = callback


@pytest.fixture(scope="module")
def model_yaml(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tedusar")
    compiled = compile_model(load_model(ROOT / "models" / "tedusar.ram"))
    (out / "model.yaml").write_text(emit_all(compiled, EmitOptions())["model.yaml"], "utf-8")
    return out / "model.yaml"


def _diagnosed(bus: FakeBus) -> bool:
    return any(
        row_diagnosis(r) == ("jaguar_node",)
        for rows in bus.published.get(DIAGNOSIS, ())
        for r in rows
    )


def test_the_engine_node_diagnoses_what_it_hears_until_the_bus_stops(model_yaml: Path) -> None:
    bus = FakeBus(_diagnosed)
    run_engine_node(bus, str(model_yaml), load_theory, "tedusar", rate_hz=20.0)
    assert _diagnosed(bus), bus.published
    assert set(bus.rows_callbacks) == {OBSERVATIONS} and set(bus.text_callbacks) == {"~reload"}
    assert bus.latched == {DIAGNOSIS: True, DIAGNOSTICS_TOPIC: False}
    assert any("jaguar_node" in rows[0].message for rows in bus.published[DIAGNOSTICS_TOPIC])
    assert bus.logged[0][1].startswith(f"racc engine: {model_yaml}")


def test_the_observer_node_publishes_runs_its_agent_and_stops_with_the_bus() -> None:
    # One loop for both ROS versions: each tick the transport's hook, the agent's requests,
    # then the host's step; the observation set is published latched.
    spec = ObserverSpec(
        "NObs", "talker_nobs", (("node", "talker"),), (Atom("running", ("talker",)),)
    )
    host = ObserverHost([spec])
    robot = Robot()
    agent = Agent("arm", {"talker": ("arm", None)}, robot)
    agent.request("start_node", "talker")
    assert agent.wait_idle(10.0)  # carried out on the agent's thread; reported by the loop
    hook_times: list[float] = []
    bus = FakeBus(lambda b: len(hook_times) >= 5)
    probe = ProcessProbe(["talker"], lambda _: None)
    run_observer_node(
        bus,
        host,
        probe,
        topics=0,
        sample_hz=50.0,
        agent=agent,
        machine="arm",
        each_tick=hook_times.append,
    )
    assert len(hook_times) == 5 and hook_times == sorted(hook_times)
    assert hook_times[-1] - hook_times[0] >= 4 / 50.0 * 0.9  # paced at 50 Hz
    assert robot.calls == [("start_node", "talker")]
    assert bus.latched == {OBSERVATIONS: True, REPAIR_LOG: True}
    assert bus.published[OBSERVATIONS], "the first tick publishes the observation set"
    lines = [text for _, text in bus.logged]
    assert lines[0] == "racc observe: 1 observers, 0 topics, 1 nodes (machine arm)"
    assert any(
        "agent(talker): start_node(talker) on machine arm: done" in line for line in lines
    ), lines
    (reported,) = [row for rows in bus.published[REPAIR_LOG] for row in rows]
    assert (reported.name, reported.hardware_id, reported.level) == ("agent", "talker", 0)


class Robot:
    """An actuator whose actions are only recorded."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, str]] = []

    def stop_node(self, node: str) -> None:
        self.calls.append(("stop_node", node))

    def kill_node(self, node: str) -> None:
        self.calls.append(("kill_node", node))

    def start_node(self, node: str) -> None:
        self.calls.append(("start_node", node))

    def switch(self, device: str, on: bool) -> None:
        self.calls.append(("power_up" if on else "shutdown", device))


def test_the_repair_node_acts_on_the_diagnosis_and_logs_it(model_yaml: Path) -> None:
    theory = load_theory(str(model_yaml))
    robot, reaped = Robot(), []
    diagnoser = Diagnoser(theory, "tedusar", "engine")
    diagnoser.observe(CRASH)
    diagnosis = list(diagnoser.tick().rows)

    def started(bus: FakeBus) -> bool:
        if bus.ticks == 3:
            bus.rows_callbacks[DIAGNOSIS](diagnosis)
        return ("start_node", "jaguar_node") in robot.calls and len(robot.calls) == 1

    bus = FakeBus(started)
    settings = Settings(confirm_s=0.1, startup_grace_s=0.0)
    job = RepairJob(theory, "tedusar", None, {}, {}, settings, rate_hz=50.0)
    run_repair_node(bus, robot, job, after_tick=lambda: reaped.append(1))
    time.sleep(0.1)  # the request runs on a thread of its own
    assert robot.calls == [("start_node", "jaguar_node")]
    assert set(bus.rows_callbacks) == {OBSERVATIONS, DIAGNOSIS}
    assert set(bus.text_callbacks) == {"~confirm"}
    assert bus.latched == {REPAIR_LOG: True, DIAGNOSTICS_TOPIC: False, REPAIR_PLAN: True}
    actions = [r.name for rows in bus.published[REPAIR_LOG] for r in rows]
    assert actions[:1] == ["plan"], actions
    (status,) = bus.published[DIAGNOSTICS_TOPIC][0]
    assert status.name == "racc_test: repair" and status.value("mode") == "act"
    assert bus.published[REPAIR_PLAN] == [[]]  # nothing awaits an operator
    assert reaped and bus.logged[0][1].startswith(
        f"racc repairer: launch file (none), {len(theory.components)} components, mode act"
    )


def test_an_advised_plan_is_published_and_executed_once_confirmed(model_yaml: Path) -> None:
    theory = load_theory(str(model_yaml))
    robot = Robot()
    diagnoser = Diagnoser(theory, "tedusar", "engine")
    diagnoser.observe(CRASH)
    diagnosis = list(diagnoser.tick().rows)

    def confirmed(bus: FakeBus) -> bool:
        if bus.ticks == 3:
            bus.rows_callbacks[DIAGNOSIS](diagnosis)
        plans = bus.published.get(REPAIR_PLAN, [])
        if len(plans) == 2 and plans[-1] and "~confirm" in bus.text_callbacks:
            bus.text_callbacks["~confirm"](plans[-1][0].value("plan"))
        return bool(robot.calls)

    bus = FakeBus(confirmed)
    settings = Settings(confirm_s=0.1, startup_grace_s=0.0, mode=Mode.ADVISE)
    job = RepairJob(theory, "tedusar", None, {}, {}, settings, rate_hz=50.0)
    run_repair_node(bus, robot, job)
    time.sleep(0.1)
    assert robot.calls == [("start_node", "jaguar_node")]
    plans = bus.published[REPAIR_PLAN]
    assert plans[0] == [] and plans[1][0].message == "start_node(jaguar_node)"
    assert plans[-1] == []  # withdrawn from the topic once confirmed
    actions = [r.name for rows in bus.published[REPAIR_LOG] for r in rows]
    assert actions[:2] == ["advise", "confirm"], actions
