"""A node in a container (its own PID namespace, ``unshare --pid``) is not confused with a
process of this host, and its crash is diagnosed (issue 28), on ROS 1 and on ROS 2.

On ROS 1 its getPid answers 1, its pid inside its namespace: racc must not watch this
host's process 1; on ROS 2 no process of this host carries its ``__node:=``.  The node is
watched through the middleware (``watched: middleware`` on its ``running`` row: the master,
or the graph), its cpu is unknown (a STALE "unknown" row, never ``ok``), and after ``kill
-9`` it is ``not_running`` and diagnosed.  On ROS 2 the graph keeps a crashed participant
until its DDS lease ends (docs/runtime.md, "Known limits"): ``not_running`` comes later
there, and the diagnosis from the talker's topic first.  Needs root for ``unshare`` (CI is
root).  The ROS 1 container restart is tests/ros1/test_placement_live.py.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from live_harness import Ros, check_runnable, environment, start_roscore
from live_procs import MONITOR, RACC, TALKER, Watcher, chat_model, contained_argv, json_lines
from soak_support import Processes

# (seconds for running(talker) watched through the middleware, bound crash -> diagnosis,
# seconds for not_running after the crash)
TIMES = {1: (20.0, 10.0, 10.0), 2: (30.0, 5.0, 40.0)}


@pytest.fixture
def graph(ros: Ros, tmp_path: Path) -> Iterator[dict[str, str]]:
    """The environment of a graph of this test's own (ROS 1: its roscore)."""
    check_runnable(ros)
    env = environment(ros, tmp_path)
    procs = Processes(env, tmp_path)
    try:
        if ros.version == 1:
            start_roscore(procs, env)
        yield env
    finally:
        procs.stop_all()


def test_a_node_in_another_pid_namespace_is_watched_through_the_middleware(
    ros: Ros, graph: dict[str, str], tmp_path: Path
) -> None:
    env = graph
    watched_s, diagnosed_s, down_s = TIMES[ros.version]
    (tmp_path / "talker.py").write_text(TALKER[ros.version], encoding="utf-8")
    (tmp_path / "monitor.py").write_text(MONITOR[ros.version], encoding="utf-8")
    build = tmp_path / "build"
    model = chat_model(tmp_path)
    subprocess.run([*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"], check=True)
    name = ["--ros-args", "-r", "__node:=talker"] if ros.version == 2 else []
    procs = Processes(env, tmp_path)
    try:
        talker = procs.start(
            contained_argv([sys.executable, str(tmp_path / "talker.py"), *name]), "talker.log"
        )
        monitor = Watcher([sys.executable, str(tmp_path / "monitor.py")], env)
        observe = Watcher([*RACC, "observe", str(build / "observers.yaml"), *ros.flag], env)
        engine = Watcher([*RACC, "engine", str(build / "model.yaml"), *ros.flag], env)
        procs.procs.extend(w.proc for w in (monitor, observe, engine))

        def messages(since: float, topic: str) -> list[tuple[float, list[Any]]]:
            return [(m["t"], m["rows"]) for m in json_lines(monitor, since) if m["topic"] == topic]

        def rows(since: float = 0.0) -> list[tuple[float, list[Any]]]:
            return [(t, r) for t, rs in messages(since, "/observations") for r in rs]

        def running_middleware() -> float | None:
            for t, (name, level, _, _, values) in rows():
                if (
                    name == "running(talker)"
                    and level == 0
                    and values.get("watched") == "middleware"
                ):
                    return float(t)
            return None

        seen = monitor.wait(running_middleware, watched_s)
        assert seen is not None, (
            "running(talker) never reported as watched through the middleware\n" + observe.text()
        )
        assert observe.wait_line("watch talker: middleware", 1) is not None
        time.sleep(2.0)  # cpu samples would have come by now
        cpu = [(lv, m) for _, (name, lv, m, _, _) in rows() if name == "ok(talker,cpu)"]
        assert cpu and all(lv == 3 and m == "unknown" for lv, m in cpu), cpu

        crash = time.time()
        os.killpg(talker.pid, signal.SIGKILL)  # the whole "container"

        def diagnosed() -> float | None:
            for t, diagnosis in messages(crash, "/diagnosis"):
                if any("talker" in row[2].split(",") for row in diagnosis):
                    return float(t)
            return None

        def not_running() -> float | None:
            for t, (name, level, _, _, _) in rows(crash):
                if name == "running(talker)" and level == 2:
                    return float(t)
            return None

        named = monitor.wait(diagnosed, 15)
        assert named is not None, "the crash of the contained talker was not diagnosed"
        down = monitor.wait(not_running, down_s)
        assert down is not None, "the crash of the contained talker was not seen"
        print(
            f"\ncontained talker ({ros.id}): diagnosed after {named - crash:.2f} s, "
            f"not_running after {down - crash:.2f} s"
        )
        assert named - crash <= diagnosed_s
        if ros.version == 1:  # ROS 2: the DDS lease (above)
            assert down - crash <= 3.0
    finally:
        procs.stop_all()
