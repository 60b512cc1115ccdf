"""``racc run`` without ROS: the launch file's arguments, read from the file, checked and
listed; and ``racc watch``'s lines (rac.runtime.watch) from status rows."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from rac.errors import RacError
from rac.runtime.launcher import launch_arguments, parse_assignments
from rac.runtime.status import Row
from rac.runtime.watch import Watch

ROOT = Path(__file__).resolve().parents[2]
RACC = [sys.executable, "-m", "rac"]


@pytest.fixture(scope="module")
def build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("run") / "build"
    subprocess.run(
        [*RACC, "compile", str(ROOT / "models" / "tedusar.ram"), "-o", str(out), "--no-svg", "-q"],
        check=True,
    )
    return out


@pytest.mark.parametrize("name", ["observers.launch", "observers.launch.xml"])
def test_arguments_come_from_the_launch_file(build: Path, name: str) -> None:
    declared = {a.name: a for a in launch_arguments(build / name)}
    assert {"robot_launch", "board", "diagnosis_rate", "model", "observers"} <= set(declared)
    assert declared["diagnosis_rate"].default == "1.0"
    given = parse_assignments(build / name, list(declared.values()), ["diagnosis_rate:=2"])
    assert given == {"diagnosis_rate": "2"}


def test_an_argument_a_new_launch_file_adds_flows_through(tmp_path: Path, build: Path) -> None:
    text = (build / "observers.launch.xml").read_text(encoding="utf-8")
    text = text.replace("<launch>", '<launch>\n  <arg name="startup_grace" default="5"/>', 1)
    path = tmp_path / "observers.launch.xml"
    path.write_text(text, encoding="utf-8")
    given = parse_assignments(path, launch_arguments(path), ["startup_grace:=9"])
    assert given == {"startup_grace": "9"}


def test_a_misspelt_argument_is_rac130_with_the_right_name(build: Path) -> None:
    path = build / "observers.launch"
    with pytest.raises(RacError) as err:
        parse_assignments(path, launch_arguments(path), ["boards:=127.0.0.1:7000"])
    d = err.value.diagnostics[0]
    assert d.code == "RAC130" and "did you mean 'board'" in (d.hint or "")


def test_racc_run_lists_the_arguments_and_refuses_a_wrong_one(build: Path) -> None:
    listed = subprocess.run(
        [*RACC, "run", str(build), "--ros", "2", "--args"], capture_output=True, text=True
    )
    assert listed.returncode == 0
    assert "board:=127.0.0.1:7000" in listed.stdout and "diagnosis_rate:=1.0" in listed.stdout
    wrong = subprocess.run(
        [*RACC, "run", str(build), "--ros", "1", "rate:=2"], capture_output=True, text=True
    )
    assert wrong.returncode == 1 and "RAC130" in wrong.stderr
    missing = subprocess.run(
        [*RACC, "run", str(build / "nowhere"), "--ros", "2"], capture_output=True, text=True
    )
    assert missing.returncode == 1 and "RAC130" in missing.stderr


def ok(atom: str, holds: bool = True) -> Row:
    return Row(atom, 0 if holds else 2, atom if holds else "not_" + atom, "obs")


def test_watch_prints_the_first_set_then_only_flips() -> None:
    watch = Watch()
    first = watch.observations([ok("ok(pose)"), ok("running(a)", False)], 0.0)
    assert len(first) == 1 and "2 literals, 1 not holding: not_running(a)" in first[0]
    assert watch.observations([ok("ok(pose)"), ok("running(a)", False)], 1.0) == []
    flipped = watch.observations([ok("ok(pose)"), ok("running(a)")], 2.0)
    assert len(flipped) == 1 and flipped[0].endswith("not_running(a) -> running(a)")


def test_watch_prints_a_diagnosis_change_once() -> None:
    watch = Watch()
    fault = [Row("diagnosis 1", 2, "jaguar_node", "tedusar")]
    assert watch.diagnosis([], 0.0)[0].endswith("no fault")
    assert watch.diagnosis(fault, 1.0)[0].endswith("1 diagnosis: {jaguar_node}")
    assert watch.diagnosis(fault, 2.0) == []
    line = watch.repair([Row("start_node", 0, "done: running(x) observed", "x")], 3.0)[0]
    assert "ok    start_node x: done: running(x) observed" in line


def test_the_fast_dds_profile_reaches_fast_dds_under_the_name_it_reads() -> None:
    from rac.ros2.common import PROFILES_V2, PROFILES_V3, align_fastdds_profiles

    env = {PROFILES_V3: "/p.xml"}
    align_fastdds_profiles(env, 2)  # Humble, Jazzy, the 2.14 wheels: only the old name
    assert env == {PROFILES_V3: "/p.xml", PROFILES_V2: "/p.xml"}
    env = {PROFILES_V2: "/p.xml"}
    align_fastdds_profiles(env, 3)  # Fast DDS 3 warns about the old name
    assert env == {PROFILES_V3: "/p.xml"}
    env = {PROFILES_V2: "/p.xml"}
    align_fastdds_profiles(env, None)  # unknown: left as the user set it
    assert env == {PROFILES_V2: "/p.xml"}


def test_racc_run_says_when_the_robots_nodes_cannot_be_restarted(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rac.ros2.run import restart_problems

    robot = tmp_path / "robot.launch.xml"
    robot.write_text('<launch>\n  <node pkg="my_robot" exec="driver" name="driver"/>\n</launch>\n')
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "nowhere"))
    (problem,) = restart_problems(str(robot))
    assert "'my_robot'" in problem and "AMENT_PREFIX_PATH" in problem
    index = tmp_path / "prefix" / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / "my_robot").write_text("")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "prefix"))
    assert restart_problems(str(robot)) == []


@pytest.mark.parametrize("ros", [1, 2])
def test_a_node_stopped_while_it_starts_ends_without_a_traceback(ros: int, tmp_path: Path) -> None:
    """racc run (and the repair engine) may stop a node that is still importing racc: that
    is a clean end, not a KeyboardInterrupt traceback (there were eight at a demo's end)."""
    import os
    import signal

    from rac.runtime.launcher import racc_command

    command = racc_command(ros, "engine")
    assert command is not None
    command.append(str(tmp_path / "model.yaml"))
    # A slow import inside racc's (PyYAML, which reading the model needs; the entries import
    # racc's modules only once their demo node's body is started): SIGINT there.
    (tmp_path / "yaml.py").write_text(
        "import sys, time\nprint('importing', file=sys.stderr, flush=True)\ntime.sleep(30)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    proc = subprocess.Popen(
        command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env
    )
    assert proc.stderr is not None
    first = proc.stderr.readline()
    assert first.strip() == "importing", first
    proc.send_signal(signal.SIGINT)
    err = proc.stderr.read()
    proc.wait(30)
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert proc.returncode == 0


def test_racc_run_restarts_a_node_that_dies_and_gives_up_on_a_crash_loop(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Issue 34: a racc node killed under racc run is started again, its loss and return
    # said; one that keeps dying (5 ends within 60 s) stops everything.
    import io

    from rac.runtime import launcher
    from rac.runtime.launcher import NodeProcess, Supervisor

    monkeypatch.setattr(launcher, "MIN_RESPAWN_DELAY_S", 0.1)
    dies = "import os, signal, time; time.sleep(0.3); os.kill(os.getpid(), signal.SIGKILL)"
    out = io.StringIO()
    supervisor = Supervisor(out, quiet=True)
    supervisor.start(NodeProcess("racc_engine", (sys.executable, "-c", dies), respawn=True), {})
    supervisor.start(
        NodeProcess("stays", (sys.executable, "-c", "import time; time.sleep(60)")), {}
    )
    try:
        assert supervisor.wait(30) == 1
    finally:
        supervisor.stop()
    text = out.getvalue()
    assert text.count("racc_engine ended by itself (killed by SIGKILL): racc lacks it") == 4
    assert text.count("restarted racc_engine (pid") == 4
    assert "racc_engine ended 5 times within 60 s (killed by SIGKILL the last time)" in text
    assert "stopped 1 nodes" in text  # the other node, stopped with it


def test_racc_run_does_not_restart_a_node_whose_input_is_wrong() -> None:
    import io

    from rac.runtime.launcher import NodeProcess, Supervisor

    out = io.StringIO()
    supervisor = Supervisor(out, quiet=True)
    bad = NodeProcess("racc_engine", (sys.executable, "-c", "raise SystemExit(1)"), respawn=True)
    supervisor.start(bad, {})
    try:
        assert supervisor.wait(20) == 1
    finally:
        supervisor.stop()
    assert "racc_engine ended by itself (exit code 1); stopping the others" in out.getvalue()
    assert "restarted" not in out.getvalue()


def test_the_compiled_launch_files_respawn_racc_and_pass_the_secret(build: Path) -> None:
    from rac.ros2.launch import load_launch

    nodes = load_launch(build / "observers.launch.xml", {"secret": "/k"})
    assert nodes and all(n.respawn and n.respawn_delay == 2.0 for n in nodes)
    assert all("--secret=/k" in n.args for n in nodes)
    text = (build / "observers.launch").read_text()
    assert text.count('respawn="true" respawn_delay="2"') == text.count('pkg="racc"')
