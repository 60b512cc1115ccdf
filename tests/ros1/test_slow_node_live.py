"""A slow answer is not an absent process (issue 34, "never two copies"), on a real ROS 1
graph: a rospy talker whose XML-RPC ``getPid`` answers after 1 s (twice racc's 0.5 s
time-out), started by ``roslaunch`` from the robot's launch file, beside racc's observer
host, engine and repairer.

Before, the talker was judged not running 2 s after its first unanswered ``getPid``; the
repairer started a second copy, and the master shut the healthy original down ("new node
registered with same name").  Now the observer host finds the talker's process by the
XML-RPC port the master has for it and watches it: no diagnosis, no plan, one copy, the
original pid alive throughout.  A real crash of the same slow talker is still repaired, by
one new copy; and when the robot's roslaunch stops, the restarted talker stops with it.
The repairer's bring-up grace is 5 s here (30 s by default) so that the old behaviour would
have shown within the test's 25 s.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from live_harness import ROS1, check_runnable, environment, start_roscore
from live_procs import (
    CHAT_PAIR_MODEL,
    LISTENER,
    MONITOR,
    RACC,
    SLOW_GETPID_S,
    SLOW_GETPID_TALKER,
    Watcher,
    chat_launch,
    chat_package,
    pids_naming,
    stop,
    topic_rows,
)
from soak_support import Processes

if not ROS1.required() and ROS1.missing() is not None:
    pytest.skip(f"ROS 1 cannot run here: {ROS1.missing()}", allow_module_level=True)

QUIET_S = 25.0  # watched without a wrong action


def _rows(monitor: Watcher, name: str, since: float = 0.0) -> list[tuple[float, int, Any]]:
    return [
        (t, r[1], r[4])
        for t, rows in topic_rows(monitor, "/observations", since)
        for r in rows
        if r[0] == name
    ]


def _actions(monitor: Watcher, since: float = 0.0) -> list[str]:
    """Every repair action on /repair_log (plans, starts, stops)."""
    return [
        f"{r[0]}: {r[2]}"
        for _, rows in topic_rows(monitor, "/repair_log", since)
        for r in rows
        if r[0] in ("plan", "start_node", "stop_node")
    ]


def test_a_slow_xmlrpc_node_is_not_restarted_and_its_crash_makes_one_copy(
    tmp_path: Path,
) -> None:
    check_runnable(ROS1)
    env = environment(ROS1, tmp_path)
    chat_package(tmp_path / "pkg", 1, {"talker": SLOW_GETPID_TALKER, "listener": LISTENER[1]})
    launch = chat_launch(tmp_path / "robot.launch", 1, ["talker", "listener"])
    (tmp_path / "chat.ram").write_text(CHAT_PAIR_MODEL, encoding="utf-8")
    (tmp_path / "monitor.py").write_text(MONITOR[1], encoding="utf-8")
    build = tmp_path / "build"
    subprocess.run(
        [*RACC, "compile", str(tmp_path / "chat.ram"), "-o", str(build), "--no-svg", "-q"],
        check=True,
    )
    procs = Processes(env, tmp_path)
    watchers: list[Watcher] = []
    started: list[int] = []

    def watch(argv: list[str], log: str) -> Watcher:
        w = Watcher(argv, env, tmp_path / log)
        watchers.append(w)
        return w

    try:
        start_roscore(procs, env)
        robot = procs.start(["roslaunch", str(launch)], "robot.log")
        monitor = watch([sys.executable, str(tmp_path / "monitor.py")], "monitor.log")
        observe = watch([*RACC, "observe", str(build / "observers.yaml")], "observe.log")
        watch([*RACC, "engine", str(build / "model.yaml")], "engine.log")
        repair = [*RACC, "repairer", str(build / "model.yaml"), "--launch", str(launch)]
        repairer = watch([*repair, "--startup-grace", "5"], "repairer.log")

        # The talker is up (registered with the master) and its first answers are late.
        up = monitor.wait(
            lambda: time.time() if pids_naming("__name:=talker", tmp_path) else None, 60
        )
        assert up is not None, "roslaunch did not start the talker"
        (original,) = pids_naming("__name:=talker", tmp_path)
        time.sleep(3.0)  # the observer host has asked it by now
        began = time.time()
        time.sleep(QUIET_S)
        # No plan, no second copy, the original alive: before, a plan started a copy
        # after the bring-up grace and the master shut the original down.
        assert _actions(monitor) == [], _actions(monitor)
        assert pids_naming("__name:=talker", tmp_path) == [original], (
            "a second copy, or the original gone"
        )
        assert "new node registered with same name" not in (tmp_path / "robot.log").read_text()
        # It is watched through its process, found by the XML-RPC port the master has for
        # it, and running(talker) stays ok: never not_running, never unknown.
        assert f"watch talker: process (getPid did not answer in time; pid {original} holds" in (
            observe.text()
        ), observe.text()
        talker_rows = _rows(monitor, "running(talker)", began)
        assert talker_rows and all(lv == 0 for _, lv, _ in talker_rows), talker_rows[-3:]
        print(
            f"\nslow getPid ({SLOW_GETPID_S:g} s): the talker (pid {original}) watched by its "
            f"XML-RPC port; {QUIET_S:g} s without a plan, one copy"
        )

        # A real crash of the slow talker: repaired by one new copy.
        crash = time.time()
        os.kill(original, signal.SIGKILL)

        def restarted() -> float | None:
            for entry in _actions(monitor, crash):
                found = re.search(r"started detached as pid (\d+)", entry)
                if entry.startswith("start_node") and found:
                    started.append(int(found.group(1)))
                    return time.time()
            return None

        assert monitor.wait(restarted, 30) is not None, repairer.text()
        back = monitor.wait(
            lambda: next(
                (t for t, lv, _ in _rows(monitor, "running(talker)", crash + 0.5) if lv == 0),
                None,
            ),
            30,
        )
        assert back is not None, observe.text()
        time.sleep(3.0)
        assert pids_naming("__name:=talker", tmp_path) == started[:1], "not exactly one copy"
        assert len([a for a in _actions(monitor, crash) if a.startswith("start_node")]) >= 1
        print(f"crash of the slow talker: running again after {back - crash:.2f} s, one copy")

        # The robot stops: the talker racc started stops with it.
        stopped = time.time()
        procs.stop(robot)
        gone = monitor.wait(
            lambda: None if pids_naming("__name:=talker", tmp_path) else time.time(), 15
        )
        assert gone is not None, "the restarted talker outlived the robot's roslaunch"
        print(f"robot stopped: the restarted talker ended {gone - stopped:.2f} s after")
    finally:
        for w in reversed(watchers):
            stop(w.proc)
        procs.stop_all()
        for pid in started:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pid, signal.SIGKILL)
