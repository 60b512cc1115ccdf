"""The robot's lifetime bounds every restart (issue 34), on ROS 1 and on ROS 2: a node racc
restarted is stopped when the robot stops, and nothing racc started remains.

The chat robot (a talker and a listener of a package 'chat') is started from its launch
file (ROS 1: ``roslaunch``; ROS 2: ``ros2 launch``, here a stand-in, since the PyPI wheels
have no ``ros2`` command), with racc's observer host, engine and repairer beside it.  The
talker is killed; racc restarts it from the launch file, detached, under its guardian.
Then the robot is stopped as an operator stops it (SIGINT to its launch; ROS 1: then its
master): the restarted talker must stop, its guardian with it, and no process naming a
node of the robot may remain.  Before the guardian, the restarted talker ran on (issue 34
found a ``rosbag play`` and a ``relay`` an hour later).
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

from live_harness import Ros, environment, start_roscore
from live_procs import (
    CHAT_PAIR_MODEL,
    LISTENER,
    MONITOR,
    RACC,
    TALKER,
    Watcher,
    chat_launch,
    chat_package,
    pids_naming,
    ros2_launch_command,
    stop,
    topic_rows,
)
from soak_support import Processes

STOPPED_S = 15.0  # the guardian sees the launch end within 0.25 s; SIGINT, 5 s, SIGTERM...


def name_arg(ros: Ros, node: str) -> str:
    return f"__node:={node}" if ros.version == 2 else f"__name:={node}"


def _row(monitor: Watcher, name: str, since: float, level: int) -> float | None:
    for t, rows in topic_rows(monitor, "/observations", since):
        if any(r[0] == name and r[1] == level for r in rows):
            return float(t)
    return None


def _started(monitor: Watcher, since: float) -> int | None:
    """The pid of the node a ``start_node`` line on /repair_log says racc started."""
    for _, rows in topic_rows(monitor, "/repair_log", since):
        for name, _, message, _, _ in rows:
            found = re.search(r"started detached as pid (\d+)", message)
            if name == "start_node" and found:
                return int(found.group(1))
    return None


def _parent(pid: int) -> int | None:
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return int(f.read().rsplit(b")", 1)[1].split()[1])
    except OSError:
        return None


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] not in (b"Z", b"X")
    except OSError:
        return False


def test_no_process_racc_started_outlives_the_robot(ros: Ros, tmp_path: Path) -> None:
    env = environment(ros, tmp_path)
    if ros.version == 2:
        env["ROS_DOMAIN_ID"] = "44"
    v = ros.version
    chat_package(tmp_path / "pkg", v, {"talker": TALKER[v], "listener": LISTENER[v]})
    launch = chat_launch(tmp_path / ros.robot_launch, v, ["talker", "listener"])
    (tmp_path / "chat.ram").write_text(CHAT_PAIR_MODEL, encoding="utf-8")
    (tmp_path / "monitor.py").write_text(MONITOR[v], encoding="utf-8")
    build = tmp_path / "build"
    subprocess.run(
        [*RACC, "compile", str(tmp_path / "chat.ram"), "-o", str(build), "--no-svg", "-q"],
        check=True,
    )
    procs = Processes(env, tmp_path)
    watchers: list[Watcher] = []
    restarted: int | None = None

    def watch(argv: list[str], log: str) -> Watcher:
        w = Watcher(argv, env, tmp_path / log)
        watchers.append(w)
        return w

    try:
        core = start_roscore(procs, env) if v == 1 else None
        if v == 1:
            robot = procs.start(["roslaunch", str(launch)], "robot.log")
        else:
            robot = procs.start(
                [str(ros2_launch_command(tmp_path)), "launch", str(launch)], "robot.log"
            )
        monitor = watch([sys.executable, str(tmp_path / "monitor.py")], "monitor.log")
        observe = watch([*RACC, "observe", str(build / "observers.yaml"), *ros.flag], "obs.log")
        watch([*RACC, "engine", str(build / "model.yaml"), *ros.flag], "engine.log")
        repairer = watch(
            [*RACC, "repairer", str(build / "model.yaml"), "--launch", str(launch), *ros.flag],
            "repairer.log",
        )
        up = monitor.wait(lambda: _row(monitor, "running(talker)", 0, 0), 60)
        assert up is not None, observe.text()
        assert monitor.wait(lambda: _row(monitor, "running(listener)", 0, 0), 30) is not None
        time.sleep(3.0)
        (talker,) = pids_naming(name_arg(ros, "talker"), tmp_path)
        crash = time.time()
        os.kill(talker, signal.SIGKILL)
        found = monitor.wait(lambda: _started(monitor, crash), 30)
        assert found is not None, repairer.text()
        restarted = int(found)
        back = monitor.wait(lambda: _row(monitor, "running(talker)", crash + 0.5, 0), 30)
        assert back is not None, repairer.text()
        guardian = _parent(restarted)
        assert guardian is not None and guardian != os.getpid()
        assert pids_naming(name_arg(ros, "talker"), tmp_path) == [restarted]  # one copy

        # The operator stops the robot: its launch (SIGINT), then (ROS 1) its master.
        stopped = time.time()
        procs.stop(robot)
        if core is not None:
            procs.stop(core)
        took = monitor.wait(lambda: None if _alive(restarted) else time.time(), STOPPED_S)
        assert took is not None, f"the restarted talker {restarted} outlived the robot"
        assert monitor.wait(lambda: None if _alive(guardian) else 1.0, 5) is not None
        log = repairer.text()
        assert "until" in log and "ends" in log, log  # the start line names the launch
        for node in ("talker", "listener"):
            assert pids_naming(name_arg(ros, node), tmp_path) == [], f"a process of {node} remains"
        print(
            f"\nlifetime ({ros.id}): restarted talker pid {restarted} running again "
            f"{back - crash:.2f} s after the kill; stopped {took - stopped:.2f} s after the "
            "robot's launch was asked to stop; nothing of the robot left"
        )
    finally:
        for w in reversed(watchers):
            stop(w.proc)
        procs.stop_all()
        if restarted is not None and _alive(restarted):
            os.killpg(restarted, signal.SIGKILL)
