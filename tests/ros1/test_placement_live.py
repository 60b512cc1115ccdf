"""A ROS 1 node in a container (its own PID namespace) is restarted by restarting its
container (issue 28), through a stand-in for docker.  The same node watched through the
middleware, on ROS 1 and ROS 2, is tests/live/test_pid_namespace_live.py.  Needs root for
``unshare`` (CI is root).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from live_harness import ROS1, check_runnable, environment, start_roscore
from live_procs import MONITOR, RACC, TALKER, Watcher, chat_model, json_lines
from soak_support import Processes

if not ROS1.required() and ROS1.missing() is not None:
    pytest.skip(f"ROS 1 cannot run here: {ROS1.missing()}", allow_module_level=True)


@pytest.fixture
def ros(tmp_path: Path) -> Iterator[tuple[dict[str, str], list[subprocess.Popen[bytes]]]]:
    """A roscore of this test's own; what the test adds to the list is stopped with it."""
    check_runnable(ROS1)
    env = environment(ROS1, tmp_path)
    procs = Processes(env, tmp_path)
    try:
        start_roscore(procs, env)
        yield env, procs.procs
    finally:
        procs.stop_all()


FAKE_DOCKER = """#!/bin/sh
# A stand-in for docker (no daemon here): the "container" {name} is the talker in its own
# PID namespace; restart starts it afresh, stop kills it.  Every call is logged.
echo "$@" >> {dir}/calls
kill_it() {{ [ -f {dir}/pid ] && kill -9 -- -"$(cat {dir}/pid)" 2>/dev/null; rm -f {dir}/pid; }}
case "$1" in
  restart) kill_it; setsid unshare --pid --fork --mount-proc {python} {talker} \\
             >> {dir}/talker.log 2>&1 & echo $! > {dir}/pid ;;
  stop) kill_it ;;
  *) exit 1 ;;
esac
"""


def test_a_contained_node_is_restarted_by_restarting_its_container(
    ros: tuple[dict[str, str], list[subprocess.Popen[bytes]]], tmp_path: Path
) -> None:
    env, procs = ros
    (tmp_path / "talker.py").write_text(TALKER[1], encoding="utf-8")
    (tmp_path / "monitor.py").write_text(MONITOR[1], encoding="utf-8")
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    docker = bin_dir / "docker"
    docker.write_text(
        FAKE_DOCKER.format(
            name="chat", dir=tmp_path, python=sys.executable, talker=tmp_path / "talker.py"
        ),
        encoding="utf-8",
    )
    docker.chmod(0o755)
    env = {**env, "PATH": f"{bin_dir}:{env['PATH']}"}
    text = chat_model(tmp_path).read_text(encoding="utf-8")
    model = chat_model(
        tmp_path, text.replace("node talker {", "node talker in container chat via docker {")
    )
    build = tmp_path / "build"
    subprocess.run([*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"], check=True)
    subprocess.run([str(docker), "restart", "chat"], env=env, check=True)
    monitor = Watcher([sys.executable, str(tmp_path / "monitor.py")], env)
    observe = Watcher([*RACC, "observe", str(build / "observers.yaml")], env)
    engine = Watcher([*RACC, "engine", str(build / "model.yaml")], env)
    repairer = Watcher([*RACC, "repairer", str(build / "model.yaml")], env)
    procs.extend(w.proc for w in (monitor, observe, engine, repairer))
    try:

        def running(since: float, level: int) -> float | None:
            for msg in json_lines(monitor, since):
                if msg["topic"] == "/observations" and any(
                    r[0] == "running(talker)" and r[1] == level for r in msg["rows"]
                ):
                    return float(msg["t"])
            return None

        assert monitor.wait(lambda: running(0, 0), 30) is not None, observe.text()
        time.sleep(2.0)
        crash = time.time()
        pid = int((tmp_path / "pid").read_text())
        os.killpg(pid, signal.SIGKILL)  # the node crashes, its "container" with it
        down = monitor.wait(lambda: running(crash, 2), 10)
        assert down is not None, "the crash of the contained talker was not seen"
        back = monitor.wait(lambda: running(down, 0), 25)
        assert back is not None, repairer.text()
        calls = (tmp_path / "calls").read_text().split("\n")
        assert "restart chat" in calls[1:], calls  # the first one is the test's own
        print(
            f"\ncontainer restart (ROS 1): not_running {down - crash:.2f} s, running again "
            f"{back - crash:.2f} s after the kill (docker calls: {calls[1:-1]})"
        )
    finally:
        if (tmp_path / "pid").exists():
            with contextlib.suppress(ProcessLookupError, ValueError):
                os.killpg(int((tmp_path / "pid").read_text()), signal.SIGKILL)
