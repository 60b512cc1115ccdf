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
from rac.runtime.trust import (
    CONFIRM,
    ENGINE,
    OBSERVER,
    OPERATOR,
    REPAIRER,
    Gate,
    Trust,
    confirm_body,
    guard_rows,
    guard_text,
)
from rac.targets import EmitOptions, emit_all

ROOT = Path(__file__).resolve().parents[2]
CRASH = Verdict(0, Atom("running", ("jaguar_node",)), False)
TIME_LIMIT_S = 20.0


KEY = bytes(range(32))  # the robot's secret in these tests


def sender(role: str, name: str) -> Trust:
    """Another racc process of the robot (or an operator), sealing with the same key."""
    return Trust(KEY, role, name, lambda level, text: None)


HOST = sender(OBSERVER, "racc_observer")
ENGINE_NODE = sender(ENGINE, "racc_engine")
ALICE = sender(OPERATOR, "alice@robot")


class Texts:
    def __init__(self, sent: list[str]) -> None:
        self.sent = sent

    def __call__(self, text: str) -> None:
        self.sent.append(text)

    def listeners(self) -> int:
        return 1


class FakeBus:
    """Records publications and subscriptions (publications sealed, subscriptions gated as
    a ROS bus does them); stops when ``done`` holds or time is up."""

    def __init__(self, done: Callable[[FakeBus], bool], role: str = OBSERVER) -> None:
        self.done = done
        self.published: dict[str, list[list[Row]]] = {}
        self.seals: dict[str, list[str]] = {}
        self.latched: dict[str, bool] = {}
        self.rows_callbacks: dict[str, Callable[[list[Row], str], None]] = {}
        self.text_callbacks: dict[str, Callable[[str], None]] = {}
        self.texts: dict[str, list[str]] = {}  # published on each topic
        self.logged: list[tuple[int, str]] = []
        self.ticks = 0
        self.deadline = time.monotonic() + TIME_LIMIT_S
        self._trust = Trust(KEY, role, self.name, self.log)

    @property
    def name(self) -> str:
        return "racc_test"

    @property
    def trust(self) -> Trust:
        return self._trust

    @property
    def ok(self) -> bool:
        self.ticks += 1
        if (
            self.ticks == 2 and OBSERVATIONS in self.rows_callbacks
        ):  # the node is set up and in its loop: the robot speaks
            self.deliver(OBSERVATIONS, [literal_row(CRASH, "jaguar_node_pobs")], HOST)
        return not self.done(self) and time.monotonic() < self.deadline

    def deliver(self, topic: str, rows: list[Row], by: Trust | None) -> None:
        """An array arrives on ``topic``, sealed by ``by`` for it (None: unsealed)."""
        self.rows_callbacks[topic](rows, by.seal_rows(topic, rows) if by is not None else "")

    def log(self, level: int, text: str) -> None:
        self.logged.append((level, text))

    def rows_publisher(
        self, topic: str, depth: int, latched: bool = False, purpose: str = ""
    ) -> Callable[[Sequence[Row]], None]:
        self.latched[topic] = latched
        sent = self.published.setdefault(topic, [])
        seals = self.seals.setdefault(topic, [])

        def publish(rows: Sequence[Row]) -> None:
            sent.append(list(rows))
            seals.append(self._trust.seal_rows(purpose, rows) if purpose else "")

        return publish

    def on_rows(
        self,
        topic: str,
        callback: Callable[[list[Row]], None],
        depth: int,
        latched: bool = False,
        gate: Gate | None = None,
    ) -> None:
        self.rows_callbacks[topic] = guard_rows(self._trust, topic, gate, callback)

    def text_publisher(self, topic: str, depth: int) -> Texts:
        return Texts(self.texts.setdefault(topic, []))

    def on_text(
        self, topic: str, callback: Callable[[str, str], None], depth: int, gate: Gate | None = None
    ) -> None:
        self.text_callbacks[topic] = guard_text(self._trust, topic, gate, callback)


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
    assert bus.latched == {OBSERVATIONS: True, REPAIR_LOG: True, DIAGNOSTICS_TOPIC: False}
    assert bus.published[OBSERVATIONS], "the first tick publishes the observation set"
    # sealed for /observations by this host, as the engine's gate admits them
    engine = sender(ENGINE, "racc_engine")
    gate = engine.gate(OBSERVATIONS)
    gate.started = 0.0
    rows, seal = bus.published[OBSERVATIONS][-1], bus.seals[OBSERVATIONS][-1]
    assert engine.check_rows(OBSERVATIONS, gate, seal, rows)
    diagnosis, ignored = bus.published[DIAGNOSTICS_TOPIC][0]
    assert (diagnosis.name, diagnosis.level) == ("racc_test: diagnosis", 0)
    assert (ignored.name, ignored.level) == ("racc_test: ignored", 0)
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
            bus.deliver(DIAGNOSIS, diagnosis, ENGINE_NODE)
        return ("start_node", "jaguar_node") in robot.calls and len(robot.calls) == 1

    bus = FakeBus(started, REPAIRER)
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
    status, ignored = bus.published[DIAGNOSTICS_TOPIC][0]
    assert status.name == "racc_test: repair" and status.value("mode") == "act"
    assert (ignored.name, ignored.level) == ("racc_test: ignored", 0)
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
            bus.deliver(DIAGNOSIS, diagnosis, ENGINE_NODE)
        plans = bus.published.get(REPAIR_PLAN, [])
        if len(plans) == 2 and plans[-1] and "~confirm" in bus.text_callbacks:
            step = plans[-1][0]
            body = confirm_body(step.value("plan"), step.value("run"))
            bus.text_callbacks["~confirm"](ALICE.seal_text(CONFIRM, body))
        return bool(robot.calls)

    bus = FakeBus(confirmed, REPAIRER)
    settings = Settings(confirm_s=0.1, startup_grace_s=0.0, mode=Mode.ADVISE)
    job = RepairJob(theory, "tedusar", None, {}, {}, settings, rate_hz=50.0)
    run_repair_node(bus, robot, job)
    time.sleep(0.1)
    assert robot.calls == [("start_node", "jaguar_node")]
    plans = bus.published[REPAIR_PLAN]
    assert plans[0] == [] and plans[1][0].message == "start_node(jaguar_node)"
    assert plans[-1] == []  # withdrawn from the topic once confirmed
    log = [r for rows in bus.published[REPAIR_LOG] for r in rows]
    assert [r.name for r in log][:2] == ["advise", "confirm"], log
    assert log[1].message == "plan 1 confirmed by alice@robot"


def test_the_engine_takes_observations_only_from_sealed_observer_hosts(model_yaml: Path) -> None:
    # A fake /observations row from an invented observer host (issue 34): unsealed, sealed
    # with another key, sealed by a racc node that is no observer host, and a replay of a
    # real host's array: none reaches the diagnosis, none makes a host "lost".
    stranger = Trust(bytes(32), OBSERVER, "racc_observer_fake", lambda level, text: None)
    repairer = sender(REPAIRER, "racc_repairer")
    crash = [literal_row(CRASH, "jaguar_node_nobs")]
    healthy = [literal_row(Verdict(0, CRASH.atom, True), "jaguar_node_nobs")]

    def attack(bus: FakeBus) -> bool:
        if bus.ticks == 3:
            receive = bus.rows_callbacks[OBSERVATIONS]
            receive(crash, "")
            receive(crash, stranger.seal_rows(OBSERVATIONS, crash))
            receive(crash, repairer.seal_rows(OBSERVATIONS, crash))
            sealed = HOST.seal_rows(OBSERVATIONS, healthy)
            receive(healthy, sealed)
            receive(crash, sealed)  # the seal of another array
            receive(healthy, sealed)  # the same array again: a replay
        return bus.ticks > 40

    bus = FakeBus(attack, ENGINE)
    # (the bus's own first delivery, the crash sealed by HOST at tick 2, is admitted)
    run_engine_node(
        bus, str(model_yaml), load_theory, "tedusar", rate_hz=50.0, hosts=("racc_observer",)
    )
    last = bus.published[DIAGNOSIS][-1]
    assert last == [], "the healthy array, the only one admitted after the crash, stands"
    ignored = bus.published[DIAGNOSTICS_TOPIC][-1][-1]
    assert ignored.name == "racc_test: ignored" and ignored.level == 1
    text = ignored.message
    for why in ("unsealed", "bad seal", "sealed by a racc repairer; only a observer", "replayed"):
        assert why in text, (why, text)
    assert not any(
        "lost" in row.message for rows in bus.published[DIAGNOSTICS_TOPIC] for row in rows
    )


def test_a_reload_outside_the_model_directory_is_refused(model_yaml: Path, tmp_path: Path) -> None:
    other = tmp_path / "model.yaml"
    other.write_text(model_yaml.read_text(), "utf-8")

    def ask(bus: FakeBus) -> bool:
        if bus.ticks == 3:
            bus.text_callbacks["~reload"](str(other))
        return bus.ticks > 20

    bus = FakeBus(ask, ENGINE)
    run_engine_node(
        bus,
        str(model_yaml),
        load_theory,
        "tedusar",
        rate_hz=50.0,
        reload_dir=str(model_yaml.parent),
    )
    assert not any("reloaded" in text for _, text in bus.logged), bus.logged
    assert any("outside the model directory" in text for _, text in bus.logged), bus.logged


def test_the_repairer_acts_only_on_a_sealed_diagnosis_and_a_sealed_confirmation(
    model_yaml: Path,
) -> None:
    theory = load_theory(str(model_yaml))
    robot = Robot()
    diagnoser = Diagnoser(theory, "tedusar", "engine")
    diagnoser.observe(CRASH)
    diagnosis = list(diagnoser.tick().rows)
    fake_operator = Trust(bytes(32), OPERATOR, "mallory", lambda level, text: None)

    def attack(bus: FakeBus) -> bool:
        if bus.ticks % 5 == 0:  # the engine's heartbeat: no fault
            bus.deliver(DIAGNOSIS, [], ENGINE_NODE)
        if bus.ticks == 3:
            bus.deliver(DIAGNOSIS, diagnosis, None)  # unsealed: no plan
        plans = bus.published.get(REPAIR_PLAN, [])
        if bus.ticks == 6:
            bus.text_callbacks["~confirm"]("1")  # a bare id, unsealed
            bus.text_callbacks["~confirm"](fake_operator.seal_text(CONFIRM, confirm_body("1")))
        return bus.ticks > 60 or bool(plans and plans[-1])

    bus = FakeBus(attack, REPAIRER)
    settings = Settings(confirm_s=0.1, startup_grace_s=0.0, mode=Mode.ADVISE)
    job = RepairJob(theory, "tedusar", None, {}, {}, settings, rate_hz=50.0)
    run_repair_node(bus, robot, job)
    assert robot.calls == []
    assert bus.published[REPAIR_PLAN][-1] == [], "no plan was made on the unsealed diagnosis"
    lines = [text for _, text in bus.logged]
    assert any("ignored /diagnosis from an unknown sender: unsealed" in t for t in lines), lines
    assert any("ignored ~confirm from mallory: bad seal" in t for t in lines), lines


def test_without_the_engines_heartbeat_the_repairer_is_blind_and_acts_on_nothing(
    model_yaml: Path,
) -> None:
    theory = load_theory(str(model_yaml))
    robot = Robot()
    diagnoser = Diagnoser(theory, "tedusar", "engine")
    diagnoser.observe(CRASH)
    diagnosis = list(diagnoser.tick().rows)
    began = time.monotonic()

    def lost_engine(bus: FakeBus) -> bool:
        if bus.ticks == 3:
            bus.deliver(DIAGNOSIS, diagnosis, ENGINE_NODE)  # then the engine dies
        return time.monotonic() - began > 1.5

    bus = FakeBus(lost_engine, REPAIRER)
    settings = Settings(confirm_s=0.6, startup_grace_s=0.0)
    job = RepairJob(theory, "tedusar", None, {}, {}, settings, rate_hz=50.0, engine_lost_s=0.3)
    run_repair_node(bus, robot, job)
    assert robot.calls == [], "a diagnosis that is not heard again is not acted on"
    log = [r for rows in bus.published[REPAIR_LOG] for r in rows]
    assert [r.name for r in log][:1] == ["blind"], log
    assert "no /diagnosis from the engine" in log[0].message
    status = bus.published[DIAGNOSTICS_TOPIC][-1][0]
    assert status.level == 2 and status.message.startswith("diagnosis blind")


def test_racc_confirm_seals_the_pending_plan_for_its_run_and_prints_the_answer() -> None:
    # The repairer's side: its latched /repair_plan, then its answer on /repair_log once a
    # confirmation it admits has come (sealed by an operator, for its run).
    repairer = sender(REPAIRER, "racc_repairer")
    gate = repairer.gate(CONFIRM)
    gate.started = 0.0
    plan = [
        Row(
            "plan 4 step 1",
            1,
            "start_node(imu_node)",
            "imu_node",
            (("plan", "4"), ("diagnosis", "{imu_node}"), ("run", "ab12")),
        )
    ]
    said: list[str] = []

    def repairer_side(bus: FakeBus) -> bool:
        if bus.ticks == 2:
            bus.rows_callbacks[REPAIR_PLAN](plan, "")
        sent = bus.texts.get("/racc_repairer/confirm", [])
        if sent and bus.ticks % 3 == 0:
            admitted = repairer.check_text("/racc_repairer/confirm", gate, sent[-1])
            assert admitted is not None, "the confirmation was not sealed for the repairer"
            body, who = admitted
            assert (who, body) == ("alice@robot", confirm_body("4", "ab12"))
            answer = Row("confirm", 0, f"plan 4 confirmed by {who}", "tedusar")
            bus.rows_callbacks[REPAIR_LOG]([answer], "")
        return False

    from rac.runtime.confirm import confirm

    bus = FakeBus(repairer_side, OPERATOR)
    bus._trust = Trust(KEY, OPERATOR, "alice@robot", bus.log)
    assert confirm(bus, "4", wait_s=5.0, say=said.append) == 0
    assert said[0] == "plan 4 (diagnosis {imu_node}) awaits confirmation:"
    assert said[-1] == "racc_repairer: plan 4 confirmed by alice@robot"


def test_racc_confirm_refuses_a_plan_that_does_not_await() -> None:
    from rac.errors import RacError
    from rac.runtime.confirm import confirm

    def nothing_pending(bus: FakeBus) -> bool:
        if bus.ticks == 2:
            bus.rows_callbacks[REPAIR_PLAN]([], "")
        return False

    bus = FakeBus(nothing_pending, OPERATOR)
    with pytest.raises(RacError) as err:
        confirm(bus, "4", wait_s=1.0, say=lambda line: None)
    assert err.value.diagnostics[0].code == "RAC151"
    assert bus.texts.get("/racc_repairer/confirm", []) == []
