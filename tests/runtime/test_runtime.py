"""The live runtime's engines without ROS: statuses, values, the host, the diagnoser, the
repair executor (with a scripted actuator and clock), the process probe and the demo."""

from __future__ import annotations

import itertools
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from rac.errors import RacError
from rac.load.files import load_model, load_observers
from rac.load.theory import load_theory, robot_name
from rac.logic import Atom
from rac.observe import NodeSample, Verdict
from rac.pipeline import compile_model
from rac.runtime.body import start_body
from rac.runtime.demo import (
    AfterRuntime,
    DemoNode,
    FaultClock,
    due_trips,
    fault_text,
    is_observer_host,
    observer_host_started,
    parse_demo_fault,
)
from rac.runtime.diagnoser import Diagnoser
from rac.runtime.host import ObserverHost
from rac.runtime.procs import ProcessProbe
from rac.runtime.repairer import LogEntry, RepairExecutor, Settings, State
from rac.runtime.status import (
    channel_rows,
    diagnosis_rows,
    literal_row,
    row_channel,
    row_diagnosis,
    row_verdict,
)
from rac.runtime.values import Decoders
from rac.targets import EmitOptions, emit_all

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"


@pytest.fixture(scope="module")
def build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tedusar")
    compiled = compile_model(load_model(TEDUSAR))
    for name, text in emit_all(compiled, EmitOptions()).items():
        (out / name).write_text(text, encoding="utf-8")
    return out


def test_literal_rows_round_trip() -> None:
    v = Verdict(1.5, Atom("ok", ("pose",)), False)
    row = literal_row(v, "pose_gobs")
    assert (row.name, row.level, row.message, row.hardware_id) == (
        "ok(pose)",
        2,
        "not_ok(pose)",
        "pose_gobs",
    )
    back = row_verdict(row, 2.0)
    assert back is not None and (back.atom, back.positive) == (v.atom, False)
    running = row_verdict(literal_row(Verdict(0, Atom("running", ("a",)), True), "x"), 0)
    assert running is not None and running.positive


def test_diagnosis_and_channel_rows(build: Path) -> None:
    theory = load_theory(str(build / "model.yaml"))
    d = Diagnoser(theory, "tedusar", "engine")
    assert diagnosis_rows(d.tick().result, "tedusar") == ()
    d.observe(Verdict(0, Atom("running", ("jaguar_node",)), False))
    tick = d.tick()
    assert tick.changed and [row_diagnosis(r) for r in tick.rows] == [("jaguar_node",)]
    assert tick.summary.level == 2 and "jaguar_node" in tick.summary.message
    rows = channel_rows([(True, 1.0, 12.0), (False, 0.0, 0.0)], {1: "jaguar"})
    assert rows[0].hardware_id == "jaguar" and rows[1].message == "off"
    state = row_channel(rows[1], 3.0)
    assert state is not None and (state.channel, state.on) == (2, False)


def test_unknown_atoms_are_set_aside(build: Path) -> None:
    d = Diagnoser(load_theory(str(build / "model.yaml")), "tedusar", "engine")
    assert not d.observe(Verdict(0, Atom("ok", ("nowhere",)), False))
    assert d.unknown == {Atom("ok", ("nowhere",))} and d.tick().result.consistent


def test_demo_messages_decode_to_the_observed_fields(build: Path) -> None:
    model = load_model(TEDUSAR)
    demo = DemoNode(model, "imu_node", epoch=100.0, started=100.0)
    (imu,) = demo.topics
    reader = Decoders().for_topic(
        "/imu_data", frozenset({"yaw", "pitch", "orientation.x"}), imu.ros_type, imu.definition
    )
    values = reader.values(demo.message(imu, 112.0))
    assert set(values) == {"yaw", "pitch", "orientation.x"}
    assert all(abs(v) < 10 for v in values.values())
    servo = DemoNode(model, "laser_alignment_control", epoch=0.0, started=0.0).topics[0]
    assert servo.ros_type == "tedusar_msgs/ServoState"


def test_demo_faults_hit_only_the_process_running_at_their_time() -> None:
    model = load_model(TEDUSAR)
    crash = parse_demo_fault("crash@10:jaguar_node", model)
    early = DemoNode(model, "jaguar_node", epoch=0.0, started=1.0, faults=[crash])
    late = DemoNode(model, "jaguar_node", epoch=0.0, started=12.0, faults=[crash])
    assert not early.crashed(9.0) and early.crashed(10.5) and not late.crashed(20.0)
    with pytest.raises(RacError) as err:
        parse_demo_fault("trip@5:imu", model)
    assert err.value.diagnostics[0].code == "RAC113"


def test_demo_faults_at_plus_t_count_from_when_the_runtime_is_seen() -> None:
    # crash@30 fired before a slow machine had the runtime up; crash@+30 waits for it.
    model = load_model(TEDUSAR)
    crash = parse_demo_fault("crash@+30:jaguar_node", model)
    assert isinstance(crash, AfterRuntime) and fault_text(crash) == "crash@+30:jaguar_node"
    seen: list[float | None] = [None]
    clock = FaultClock(0.0, lambda: seen[0])
    node = DemoNode(model, "jaguar_node", epoch=0.0, started=1.0, faults=[crash], clock=clock)
    assert not node.crashed(40.0)  # no runtime yet: 30 s after the epoch means nothing
    seen[0] = 100.0  # the observer host started at 100
    node.clock._next_look = 0.0  # looked for again at once
    assert not node.crashed(129.0) and node.crashed(130.5)
    restarted = DemoNode(
        model, "jaguar_node", epoch=0.0, started=135.0, faults=[crash], clock=clock
    )
    assert not restarted.crashed(140.0)  # the node the repair engine started is healthy
    trip = parse_demo_fault("trip@+5:jaguar", model)
    absolute = parse_demo_fault("trip@50:jaguar", model)
    pending = [trip, absolute]
    assert due_trips(pending, clock, 104.0) == [absolute] and pending == [trip]
    assert due_trips(pending, clock, 105.0) == [trip] and not pending
    with pytest.raises(RacError) as err:
        parse_demo_fault("slip@+5:/odom", model)
    assert err.value.diagnostics[0].code == "RAC113"


def test_the_runtime_is_seen_by_its_observer_hosts_process(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert is_observer_host(["/usr/bin/python3", "/opt/bin/racc", "observe", "o.yaml"])
    assert is_observer_host(["python", "-m", "rac", "observe", "o.yaml"])
    assert is_observer_host(["observe", "o.yaml", "--ros-args", "-r", "__node:=racc_observer_b"])
    assert not is_observer_host(["racc", "engine", "model.yaml", "__name:=racc_engine"])
    uri = f"http://127.0.0.1:1/{tmp_path.name}"  # a graph of this test alone
    monkeypatch.setenv("ROS_MASTER_URI", uri)
    assert observer_host_started() is None
    host = [sys.executable, "-c", "import time; time.sleep(30)", "__name:=racc_observer"]
    other = subprocess.Popen(host, env={**os.environ, "ROS_MASTER_URI": uri + "x"})
    ours = subprocess.Popen(host)
    try:
        deadline = time.time() + 10
        while observer_host_started() is None and time.time() < deadline:
            time.sleep(0.1)
        assert observer_host_started() == psutil.Process(ours.pid).create_time()
    finally:
        for proc in (ours, other):
            proc.kill()
            proc.wait()


def test_demo_body_outlives_ctrl_c_quietly_and_ends_with_its_stdin() -> None:
    # Ctrl-C reaches the whole process group: the body must not print a traceback for
    # it, and still end when its node does (stdin closed).
    body = start_body()
    try:
        time.sleep(0.3)  # past the interpreter's start, into the loop
        body.send_signal(signal.SIGINT)
        time.sleep(0.2)
        assert body.poll() is None
    finally:
        assert body.stdin is not None
        body.stdin.close()
    assert body.wait(timeout=5) == 0


def test_host_reports_changes_and_rows(build: Path) -> None:
    _, specs = load_observers(build / "observers.yaml")
    now = [0.0]
    host = ObserverHost(specs, clock=lambda: now[0])
    for k in range(8):
        now[0] = k * 0.1
        host.feed([NodeSample(now[0], "jaguar_node", False)])
    # The θ rule: the first sample gives the first verdict, θ + 1 net violations flip it.
    changes = [str(c) for c in host.take_changes()]
    assert changes == ["running(jaguar_node)", "not_running(jaguar_node)"]
    (row,) = host.rows()
    assert row.hardware_id == "jaguar_node_nobs" and row.level == 2


def test_process_probe_asks_once_then_uses_the_pid() -> None:
    asked: list[str] = []

    def resolve(node: str) -> int | None:
        asked.append(node)
        return os.getpid() if node == "me" else None

    probe = ProcessProbe(["me", "gone"], resolve, [("me", "mem")], settle_s=0)
    first = probe.sample(0.0)
    later = probe.sample(0.1)
    assert asked == ["gone", "me"]  # "gone" is asked again only after resolve_every_s
    assert [type(e).__name__ for e in first] == ["NodeSample", "NodeSample", "PropertySample"]
    assert [(e.node, e.running) for e in later if isinstance(e, NodeSample)] == [
        ("gone", False),
        ("me", True),
    ]


class Script:
    """A fake robot: actions change the observations the executor sees, or do nothing."""

    def __init__(self, executor_box: list[RepairExecutor], works: bool = True) -> None:
        self.box, self.works, self.calls = executor_box, works, []  # type: ignore[var-annotated]

    def _set(self, atom: Atom, positive: bool) -> None:
        if self.works:
            self.box[0].observe(Verdict(0, atom, positive))

    def stop_node(self, node: str) -> None:
        self.calls.append(("stop_node", node))
        self._set(Atom("running", (node,)), False)

    def start_node(self, node: str) -> None:
        self.calls.append(("start_node", node))
        self._set(Atom("running", (node,)), True)

    def switch(self, device: str, on: bool) -> None:
        self.calls.append(("power_up" if on else "shutdown", device))
        self._set(Atom("on", (device,)), on)


def _executor(
    build: Path, works: bool
) -> tuple[RepairExecutor, Script, list[LogEntry], list[float]]:
    theory = load_theory(str(build / "model.yaml"))
    now = [0.0]
    log: list[LogEntry] = []
    box: list[RepairExecutor] = []
    script = Script(box, works)
    ex = RepairExecutor(
        theory,
        "tedusar",
        script,  # type: ignore[arg-type]  # a fake robot without kill_node: never asked here
        log.append,
        clock=lambda: now[0],
        settings=Settings(
            confirm_s=0.5, startup_grace_s=0.0, step_timeout_s=1.0, verify_timeout_s=2.0
        ),
    )
    box.append(ex)
    return ex, script, log, now


def test_executor_restarts_a_crashed_node_and_verifies(build: Path) -> None:
    ex, script, log, now = _executor(build, works=True)
    ex.observe(Verdict(0, Atom("running", ("jaguar_node",)), False))
    ex.diagnosis((("jaguar_node",),))
    for k in range(10):
        now[0] = 0.1 * k
        ex.tick()
    assert script.calls == [("start_node", "jaguar_node")]
    assert ex.state is State.VERIFYING
    now[0] = 1.5
    ex.diagnosis(())
    ex.tick()
    assert ex.state is State.IDLE and ex.repairs == 1  # type: ignore[comparison-overlap]  # mypy keeps the narrowing across the calls above
    assert [e.action for e in log] == ["plan", "start_node", "start_node", "verify"]


def test_executor_repairs_a_fault_that_appears_during_a_repair_at_once(build: Path) -> None:
    # hokuyo_node crashes while jaguar_node is being restarted: once jaguar_node is back,
    # the standing diagnosis names only hokuyo_node, so the repair is verified and
    # hokuyo_node restarted without waiting out the verification's time-out (2 s here).
    ex, script, log, now = _executor(build, works=True)
    ex.observe(Verdict(0, Atom("running", ("jaguar_node",)), False))
    ex.diagnosis((("jaguar_node",),))
    for k in range(8):
        now[0] = 0.1 * k
        ex.tick()
    assert ex.state is State.VERIFYING
    ex.observe(Verdict(0, Atom("running", ("hokuyo_node",)), False))
    ex.diagnosis((("hokuyo_node", "jaguar_node"),))  # stale: still names jaguar_node
    for k in range(8, 15):
        now[0] = 0.1 * k
        ex.tick()
    assert ex.state is State.VERIFYING  # a diagnosis naming the repaired node: wait
    ex.diagnosis((("hokuyo_node",),))
    for k in range(15, 22):
        now[0] = 0.1 * k
        ex.tick()
    assert script.calls == [("start_node", "jaguar_node"), ("start_node", "hokuyo_node")]
    verify = [e for e in log if e.action == "verify"]
    assert [e.level for e in verify] == [0]
    assert "a new fault remains: {hokuyo_node}" in verify[0].message
    assert ex.repairs == 1 and ex.escalations == 0


def test_executor_retries_once_then_escalates(build: Path) -> None:
    ex, script, log, now = _executor(build, works=False)
    ex.observe(Verdict(0, Atom("running", ("jaguar_node",)), False))
    ex.diagnosis((("jaguar_node",),))
    for k in range(40):
        now[0] = 0.1 * k
        ex.tick()
    assert script.calls == [("start_node", "jaguar_node")] * 2
    assert ex.escalations == 1 and ex.state is State.IDLE
    assert any(e.action == "escalate" and "RAC110" in e.message for e in log)


def test_observers_yaml_errors(tmp_path: Path) -> None:
    bad = tmp_path / "observers.yaml"
    bad.write_text("observers: 3\n")
    with pytest.raises(RacError) as err:
        load_observers(bad)
    assert err.value.diagnostics[0].code == "RAC056"


def test_without_ros_the_nodes_say_how_to_get_it(
    build: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import importlib.util

    if importlib.util.find_spec("rospy") is not None:
        pytest.skip("rospy is importable here")
    from rac.cli import main

    assert main(["engine", str(build / "model.yaml")]) == 1
    err = capsys.readouterr().err
    assert "RAC057" in err and "--system-site-packages" in err


def test_robot_name_of_a_compiled_model_yaml_is_the_models_not_its_directorys(
    build: Path, tmp_path: Path
) -> None:
    # /diagnosis, /diagnostics and /repair_log name the robot (docs/runtime.md): compiled
    # into build/, tedusar is still 'tedusar'; a hand-written file keeps its directory's.
    out = tmp_path / "build"
    out.mkdir()
    text = (build / "model.yaml").read_text(encoding="utf-8")
    (out / "model.yaml").write_text(text, encoding="utf-8")
    path = str(out / "model.yaml")
    assert robot_name(load_theory(path), path) == "tedusar"
    (out / "model.yaml").write_text(text.split("\n", 1)[1], encoding="utf-8")
    assert robot_name(load_theory(path), path) == "build"


def test_one_master_is_one_graph_however_its_uri_is_spelled() -> None:
    """Issue 38: roslaunch gives the demo's nodes ROS_MASTER_URI=http://localhost:11311/;
    `racc run` on a stock Debian has none, so @+T faults never fired."""
    from rac.runtime.demo import ros_graph

    default = ros_graph({})
    assert ros_graph({"ROS_MASTER_URI": "http://localhost:11311/"}) == default
    assert ros_graph({"ROS_MASTER_URI": "http://127.0.0.1:11311"}) == default
    assert ros_graph({"ROS_MASTER_URI": " http://LOCALHOST:11311/ ", "ROS_DOMAIN_ID": ""}) == (
        default
    )
    assert ros_graph({"ROS_DOMAIN_ID": "0"}) == default
    assert ros_graph({"ROS_MASTER_URI": "http://localhost:11312/"}) != default
    assert ros_graph({"ROS_MASTER_URI": "http://robot1:11311/"}) != default
    assert ros_graph({"ROS_DOMAIN_ID": "38"}) != default
    assert ros_graph({"ROS_MASTER_URI": "not a uri"}) != default


def test_an_observer_host_is_seen_whatever_spelling_of_its_master_it_was_given(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from live_procs import free_port

    port = free_port()  # a master no other process names
    monkeypatch.setenv("ROS_MASTER_URI", f"http://127.0.0.1:{port}")
    assert observer_host_started() is None
    host = [sys.executable, "-c", "import time; time.sleep(30)", "__name:=racc_observer"]
    theirs = subprocess.Popen(
        host, env={**os.environ, "ROS_MASTER_URI": f"http://localhost:{port}/"}
    )
    try:
        deadline = time.time() + 10
        while observer_host_started() is None and time.time() < deadline:
            time.sleep(0.1)
        assert observer_host_started() == psutil.Process(theirs.pid).create_time()
    finally:
        theirs.kill()
        theirs.wait()


def test_a_demo_node_sends_no_clump_when_its_first_message_is_slow() -> None:
    """Issue 38: on ROS 2 the observer host is subscribed before a demo node's first
    message; the first publication (serializer generated, transport connected) took about
    0.25 s and the node caught up with a clump of 9 /scan messages, which the host judged
    too fast: not_ok(scan) and {hokuyo} | {hokuyo_node} for a second, 2 s in."""
    import types

    from rac.runtime.demo import DemoRunner

    model = load_model(TEDUSAR)
    now = time.time()
    demo = DemoNode(model, "hokuyo_node", epoch=now, started=now)
    sent: list[float] = []

    def publish(topic: object, at: float) -> None:
        if not sent:
            time.sleep(0.3)  # the slow first publication
        sent.append(time.time())

    body = types.SimpleNamespace(stdin=None)
    runner = DemoRunner(demo, body, publish, lambda rows: None, lambda level, text: None)  # type: ignore[arg-type]
    start = time.time()
    while time.time() < start + 0.8:
        runner.step()
    gaps = [b - a for a, b in itertools.pairwise(sent)]
    clumped = sum(1 for g in gaps if g < 0.005)  # /scan is 40 Hz: 25 ms apart
    assert len(sent) > 10 and clumped <= 1, [round(g * 1000) for g in gaps]
