"""A ROS 1 node in a container (its own PID namespace, ``unshare --pid``) is not confused
with a process of this host, and its crash is diagnosed (issue 28).

Its getPid answers 1, its pid inside its namespace: racc must not watch this host's
process 1.  The node is watched through the master (``watched: middleware`` on its
``running`` row), its cpu is unknown (a STALE "unknown" row, never ``ok``), and after
``kill -9`` it is ``not_running`` and diagnosed.  Needs root for ``unshare`` (CI is root).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

if os.environ.get("RACC_REQUIRE_ROS") == "1":
    import rospy  # noqa: F401
else:
    pytest.importorskip("rospy", reason="ROS 1 (python3-rospy) is not importable")
if shutil.which("roscore") is None:
    pytest.skip("roscore is not installed", allow_module_level=True)

from live_procs import (
    RACC,
    Watcher,
    chat_model,
    contained_argv,
    free_port,
    json_lines,
    start_roscore,
    stop,
)

TALKER = """
import sys, rospy
from std_msgs.msg import String
rospy.init_node("talker")
pub = rospy.Publisher("/chatter", String, queue_size=10)
rate = rospy.Rate(10)
while not rospy.is_shutdown():
    pub.publish(String(data="hello"))
    rate.sleep()
"""

MONITOR = """
import json, sys, time, rospy
from diagnostic_msgs.msg import DiagnosticArray
rospy.init_node("racc_placement_monitor", anonymous=True)
def show(topic):
    def cb(a):
        rows = [[s.name, s.level, s.message, {v.key: v.value for v in s.values}] for s in a.status]
        print(json.dumps({"t": time.time(), "topic": topic, "rows": rows}), flush=True)
    return cb
rospy.Subscriber("/observations", DiagnosticArray, show("/observations"))
rospy.Subscriber("/diagnosis", DiagnosticArray, show("/diagnosis"))
rospy.spin()
"""


@pytest.fixture
def ros(tmp_path: Path) -> Iterator[tuple[dict[str, str], list[subprocess.Popen[bytes]]]]:
    port = free_port()
    env = dict(os.environ)
    env.update(
        ROS_MASTER_URI=f"http://127.0.0.1:{port}",
        ROS_IP="127.0.0.1",
        ROS_HOME=str(tmp_path / "ros_home"),
        PYTHONUNBUFFERED="1",
    )
    procs: list[subprocess.Popen[bytes]] = []
    procs.append(start_roscore(port, env, tmp_path / "roscore.log"))
    try:
        yield env, procs
    finally:
        for proc in reversed(procs):
            stop(proc)


def test_a_node_in_another_pid_namespace_is_watched_through_the_master(
    ros: tuple[dict[str, str], list[subprocess.Popen[bytes]]], tmp_path: Path
) -> None:
    env, procs = ros
    (tmp_path / "talker.py").write_text(TALKER, encoding="utf-8")
    (tmp_path / "monitor.py").write_text(MONITOR, encoding="utf-8")
    build = tmp_path / "build"
    model = chat_model(tmp_path)
    subprocess.run([*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"], check=True)
    talker = subprocess.Popen(
        contained_argv([sys.executable, str(tmp_path / "talker.py")]),
        env=env,
        start_new_session=True,
    )
    procs.append(talker)
    monitor = Watcher([sys.executable, str(tmp_path / "monitor.py")], env)
    observe = Watcher([*RACC, "observe", str(build / "observers.yaml")], env)
    engine = Watcher([*RACC, "engine", str(build / "model.yaml")], env)
    procs.extend(w.proc for w in (monitor, observe, engine))

    def rows(since: float = 0.0) -> list[tuple[float, list[Any]]]:
        return [
            (msg["t"], row)
            for msg in json_lines(monitor, since)
            if msg["topic"] == "/observations"
            for row in msg["rows"]
        ]

    def running_middleware() -> float | None:
        for t, (name, level, _, values) in rows():
            if name == "running(talker)" and level == 0 and values.get("watched") == "middleware":
                return t
        return None

    seen = monitor.wait(running_middleware, 20)
    assert seen is not None, "running(talker) never reported as watched through the master"
    assert observe.wait_line("watch talker: middleware", 1) is not None
    time.sleep(2.0)  # cpu samples would have come by now
    cpu = [(level, message) for _, (name, level, message, _) in rows() if name == "ok(talker,cpu)"]
    assert cpu and all(level == 3 and message == "unknown" for level, message in cpu), cpu

    crash = time.time()
    os.killpg(talker.pid, signal.SIGKILL)  # the whole "container"

    def not_running() -> float | None:
        for t, (name, level, _, _) in rows(crash):
            if name == "running(talker)" and level == 2 and t >= crash:
                return t
        return None

    def diagnosed() -> float | None:
        for msg in json_lines(monitor, crash):
            if msg["topic"] == "/diagnosis" and any(
                "talker" in row[2].split(",") for row in msg["rows"]
            ):
                return float(msg["t"])
        return None

    down = monitor.wait(not_running, 10)
    assert down is not None, "the crash of the contained talker was not seen"
    named = monitor.wait(diagnosed, 10)
    assert named is not None, "the crash of the contained talker was not diagnosed"
    print(
        f"\ncontained talker (ROS 1): not_running after {down - crash:.2f} s, "
        f"diagnosed after {named - crash:.2f} s"
    )
    assert down - crash <= 3.0


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
    (tmp_path / "talker.py").write_text(TALKER, encoding="utf-8")
    (tmp_path / "monitor.py").write_text(MONITOR, encoding="utf-8")
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
