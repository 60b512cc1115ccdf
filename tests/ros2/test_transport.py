"""The ROS 2 transport's pieces that need no ROS: argument splitting, transport choice,
the installed package, launch entries to command lines, and finding a node's process."""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from rac.commands.common import ros_version
from rac.errors import RacError
from rac.load.ros_package import write_package
from rac.ros2.args import split_ros_args
from rac.ros2.launch import command_line, load_launch
from rac.runtime.procs import innermost, node_processes, outermost


def test_ros_args_are_split_off() -> None:
    argv = ["m.yaml", "--rate", "2", "--ros-args", "-r", "__node:=x", "--", "--max-card", "1"]
    assert split_ros_args(argv) == (
        ["m.yaml", "--rate", "2", "--max-card", "1"],
        ["--ros-args", "-r", "__node:=x"],
    )


def test_transport_from_option_then_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_VERSION", "2")
    assert ros_version(argparse.Namespace(ros=None)) == 2
    assert ros_version(argparse.Namespace(ros=1)) == 1
    monkeypatch.setenv("ROS_VERSION", "1")
    assert ros_version(argparse.Namespace(ros=None)) == 1


def test_package_prefix_and_launch_entries(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    prefix = write_package(tmp_path / "install", ros=2)
    assert (prefix / "share/ament_index/resource_index/packages/racc").is_file()
    assert (prefix / "share/racc/package.xml").read_text().count("<name>racc</name>") == 1
    observe = prefix / "lib/racc/observe"
    assert observe.stat().st_mode & 0o111 and observe.read_text().startswith(f"#!{sys.executable}")
    launch = tmp_path / "robot.launch.xml"
    launch.write_text(
        '<launch><arg name="rate" default="5"/>'
        '<node pkg="racc" exec="observe" name="obs" namespace="bot" '
        'args="o.yaml --rate $(var rate)">'
        '<param name="k" value="1"/><remap from="/a" to="/b"/></node></launch>'
    )
    # Not found without the prefix (test_live's fixture leaves its own in the environment).
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    with pytest.raises(RacError) as missing:
        command_line(load_launch(launch)[0])
    assert missing.value.diagnostics[0].code == "RAC118"
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(prefix))
    (entry,) = load_launch(launch, {"rate": "7"})
    assert entry.key == "bot/obs"
    assert command_line(entry) == [
        str(observe), "o.yaml", "--rate", "7", "--ros-args", "-r", "__node:=obs",
        "-r", "__ns:=/bot", "-p", "k:=1", "-r", "/a:=/b",
    ]  # fmt: skip
    launch.write_text('<launch><node pkg="p" exec="e" args="$(var nope)"/></launch>')
    with pytest.raises(RacError) as bad:
        load_launch(launch)
    assert bad.value.diagnostics[0].code == "RAC117"


def test_a_node_is_its_innermost_process() -> None:
    """A wrapper (as ros2 run) and the process it starts carry the same __node:=."""
    child = "import subprocess, sys, time; time.sleep(30)"
    wrapper = (
        "import subprocess, sys; subprocess.run([sys.executable, '-c', sys.argv[1], "
        "'--ros-args', '-r', '__node:=racc_test_probe_node'])"
    )
    args = [
        sys.executable,
        "-c",
        wrapper,
        child,
        "--ros-args",
        "-r",
        "__node:=racc_test_probe_node",
    ]
    outer = subprocess.Popen(args)
    try:
        deadline = time.time() + 10
        found: list[psutil.Process] = []
        while time.time() < deadline and len(found) < 2:
            found = node_processes("racc_test_probe_node")
            time.sleep(0.1)
        assert len(found) == 2
        inner = innermost(found)
        assert inner is not None and inner.pid != outer.pid and inner.ppid() == outer.pid
        assert [p.pid for p in outermost(found)] == [outer.pid]
        assert node_processes("other/racc_test_probe_node") == []
    finally:
        for p in node_processes("racc_test_probe_node"):
            p.kill()
        outer.wait(5)


def test_the_ros2_actuator_starts_detached_stops_politely_and_kills(tmp_path: Path) -> None:
    import os
    import signal

    from rac.ros2.actuator import Ros2Actuator
    from rac.runtime.detached import Detached

    actuator = Ros2Actuator.__new__(Ros2Actuator)  # no rclpy session: switching is not tested
    actuator.launch_file, actuator.entries, actuator.detached = None, {}, Detached()
    actuator.robot, actuator.robot_gone_s = (), 30.0
    sleeper = f"{sys.executable} -c 'import time; time.sleep(60)' --ros-args -r __node:={{node}}"
    actuator.restart = sleeper
    os.environ["ROS_LOG_DIR"] = str(tmp_path)
    try:
        note = actuator.start_node("racc_test_sleeper")
    finally:
        del os.environ["ROS_LOG_DIR"]
    pid = actuator.detached.pid("racc_test_sleeper")
    assert pid is not None and f"pid {pid}" in note and "keeps running when racc stops" in note
    assert os.getsid(pid) == pid != os.getsid(0)  # its own session: it outlives racc
    assert [p.pid for p in node_processes("racc_test_sleeper")] == [pid]
    assert "SIGINT" in actuator.stop_node("racc_test_sleeper")
    actuator.detached.procs["racc_test_sleeper"].guardian.wait(10)  # it ends with its node
    # A node racc did not start and that ignores SIGINT (frozen, or stubborn) is killed.
    stubborn = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); time.sleep(60)",
            "__node:=racc_test_stubborn",
        ]
    )
    try:
        time.sleep(0.5)
        assert "SIGKILL" in actuator.kill_node("racc_test_stubborn")
        assert stubborn.wait(10) == -signal.SIGKILL
    finally:
        if stubborn.poll() is None:
            stubborn.kill()
    # No process left and not in the graph: it stopped (the observers confirm it).
    assert "it stopped" in actuator.kill_node("racc_test_nowhere")
    # In the graph without a local process: on another machine, out of reach.
    actuator._graph = lambda: {"racc_test_remote"}  # type: ignore[method-assign]
    with pytest.raises(RacError) as err:
        actuator.kill_node("racc_test_remote")
    assert err.value.diagnostics[0].code == "RAC124"
