"""A ROS 1 robot on two computers (issue 28), without a second computer: two network
namespaces joined by a veth pair, ``base`` (the master, the engine, the repairer, a
listener) and ``second`` (a talker).  Each machine has its own observer host (``racc
observe --machine``); the talker's process is watched by the host of its machine, its
crash is diagnosed, and it is restarted there by that machine's racc agent; when the
second host goes, its atoms become unknown and the engine reports the host lost.

Needs root for ``ip netns`` (CI is root).  Everything runs inside the two namespaces and
binds only to their addresses; both are deleted at the end, with what runs in them.
"""

from __future__ import annotations

import os
import shutil
import signal
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

from live_procs import RACC, NetPair, Watcher, can_make_netns, free_port, json_lines, stop

if not can_make_netns():
    pytest.skip("ip netns needs root and iproute2 (CI runs as root)", allow_module_level=True)

TALKER = """import rospy
from std_msgs.msg import String
rospy.init_node("talker")
pub = rospy.Publisher("/chatter", String, queue_size=10)
rate = rospy.Rate(10)
while not rospy.is_shutdown():
    pub.publish(String(data="hello"))
    rate.sleep()
"""

LISTENER = """import rospy
from std_msgs.msg import String
rospy.init_node("listener")
rospy.Subscriber("/chatter", String, lambda m: None)
rospy.spin()
"""

MONITOR = """import json, time, rospy
from diagnostic_msgs.msg import DiagnosticArray
rospy.init_node("racc_multihost_monitor", anonymous=True)
def show(topic):
    def cb(a):
        rows = [[s.name, s.level, s.message, s.hardware_id, {v.key: v.value for v in s.values}]
                for s in a.status]
        print(json.dumps({"t": time.time(), "topic": topic, "rows": rows}), flush=True)
    return cb
for topic in ("/observations", "/diagnosis", "/repair_log", "/diagnostics"):
    rospy.Subscriber(topic, DiagnosticArray, show(topic))
rospy.spin()
"""

MODEL = """robot duo
machine base address {a}
machine second address {b}
topic /chatter : std_msgs/String @ 10 Hz
node talker on second {{
  publishes /chatter
  limits cpu 90 %, mem 900 MB
}}
node listener on base {{ subscribes /chatter }}
"""

ROBOT_LAUNCH = """<launch>
  <node pkg="chat" type="talker" name="talker"/>
  <node pkg="chat" type="listener" name="listener"/>
</launch>
"""


def _package(tmp: Path) -> Path:
    """A ROS package 'chat' whose talker and listener roslaunch can start."""
    pkg = tmp / "pkg" / "chat"
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text(
        '<?xml version="1.0"?>\n<package format="2"><name>chat</name><version>0.0.0</version>'
        "<description>test</description><maintainer email='a@b.c'>a</maintainer>"
        "<license>MIT</license></package>\n",
        encoding="utf-8",
    )
    for name, body in (("talker", TALKER), ("listener", LISTENER)):
        exe = pkg / name
        exe.write_text(f"#!{sys.executable}\n{body}", encoding="utf-8")
        exe.chmod(0o755)
    return tmp / "pkg"


@pytest.fixture
def net() -> Iterator[NetPair]:
    pair = NetPair().open()
    try:
        yield pair
    finally:
        pair.close()


class Robot:
    def __init__(self, net: NetPair, tmp: Path) -> None:
        self.net, self.tmp = net, tmp
        self.port = free_port()
        self.env = dict(os.environ)
        self.env.update(
            ROS_MASTER_URI=f"http://{net.addresses['a']}:{self.port}",
            ROS_HOME=str(tmp / "ros_home"),
            ROS_PACKAGE_PATH=str(_package(tmp)),
            PYTHONUNBUFFERED="1",
        )
        self.watchers: list[Watcher] = []

    def start(self, where: str, argv: list[str], log: str) -> Watcher:
        env = {**self.env, "ROS_IP": self.net.addresses[where]}
        w = Watcher(self.net.argv(where, argv), env, self.tmp / log)
        self.watchers.append(w)
        return w

    def close(self) -> None:
        for w in reversed(self.watchers):
            stop(w.proc)


def _messages(monitor: Watcher, topic: str, since: float = 0.0) -> list[tuple[float, Any]]:
    return [(m["t"], m["rows"]) for m in json_lines(monitor, since) if m["topic"] == topic]


def _row(monitor: Watcher, name: str, since: float, level: int) -> float | None:
    for t, rows in _messages(monitor, "/observations", since):
        if any(r[0] == name and r[1] == level for r in rows):
            return t
    return None


def test_a_node_on_a_second_host_is_observed_and_repaired_there(
    net: NetPair, tmp_path: Path
) -> None:
    model = tmp_path / "duo.ram"
    model.write_text(MODEL.format(a=net.addresses["a"], b=net.addresses["b"]), encoding="utf-8")
    (tmp_path / "robot.launch").write_text(ROBOT_LAUNCH, encoding="utf-8")
    (tmp_path / "monitor.py").write_text(MONITOR, encoding="utf-8")
    build = tmp_path / "build"
    import subprocess

    subprocess.run([*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"], check=True)
    observers, launch = str(build / "observers.yaml"), str(tmp_path / "robot.launch")
    robot = Robot(net, tmp_path)
    try:
        core = robot.start("a", ["roscore", "-p", str(robot.port)], "roscore.log")
        assert core.wait_line("started core service", 30) is not None, core.text()
        pkg = tmp_path / "pkg" / "chat"
        talker = robot.start("b", [str(pkg / "talker"), "__name:=talker"], "talker.log")
        robot.start("a", [str(pkg / "listener"), "__name:=listener"], "listener.log")
        monitor = robot.start("a", [sys.executable, str(tmp_path / "monitor.py")], "monitor.log")
        second = robot.start(
            "b",
            [*RACC, "observe", observers, "--machine", "second", "--launch", launch],
            "observe_second.log",
        )
        robot.start("a", [*RACC, "observe", observers, "--machine", "base"], "observe_base.log")
        engine = robot.start("a", [*RACC, "engine", str(build / "model.yaml")], "engine.log")
        robot.start(
            "a",
            [*RACC, "repairer", str(build / "model.yaml"), "--launch", launch, "--machine", "base"],
            "repair.log",
        )

        # The talker is watched by the host of its machine, through its proven process.
        def watched_there() -> float | None:
            for t, rows in _messages(monitor, "/observations"):
                for name, level, _, _, values in rows:
                    if (
                        name == "running(talker)"
                        and level == 0
                        and values.get("host") == "racc_observer_second"
                        and values.get("watched") == "process"
                    ):
                        return t
            return None

        assert monitor.wait(watched_there, 40) is not None, second.text()
        healthy = monitor.wait(lambda: _row(monitor, "ok(talker,cpu)", 0, 0), 10)
        assert healthy is not None, "ok(talker,cpu) never reported by the second host"
        time.sleep(3.0)  # the repairer's agent publisher connects

        crash = time.time()
        os.kill(talker.proc.pid, signal.SIGKILL)  # 'ip netns exec' execs: this is the talker
        down = monitor.wait(lambda: _row(monitor, "running(talker)", crash, 2), 10)
        assert down is not None, "the crash on the second host was not seen"

        def diagnosed() -> float | None:
            for t, rows in _messages(monitor, "/diagnosis", crash):
                if any("talker" in r[2].split(",") for r in rows):
                    return t
            return None

        named = monitor.wait(diagnosed, 10)
        assert named is not None, "the crash on the second host was not diagnosed"
        assert second.wait_line("agent second: start_node(talker) done", 20, crash) is not None, (
            second.text()
        )
        back = monitor.wait(lambda: _row(monitor, "running(talker)", named, 0), 20)
        assert back is not None, "the talker did not come back"
        # Restarted on the second machine: its new process is in that namespace.
        restarted = [p for p in net.pids("b") if p != talker.proc.pid and _is_talker(p)]
        assert restarted and all(net.identify(p) == net.names["b"] for p in restarted)
        print(
            f"\nsecond host (ROS 1): not_running {down - crash:.2f} s, diagnosed "
            f"{named - crash:.2f} s, running again {back - crash:.2f} s after the kill"
        )
        assert down - crash <= 3.0 and named - crash <= 3.0

        # The second host goes: its atoms become unknown, and its loss is reported.
        gone = time.time()
        os.kill(second.proc.pid, signal.SIGKILL)
        lost = engine.wait_line("observer host racc_observer_second lost", 15, gone)
        assert lost is not None, engine.text()
        print(f"second host lost: reported {lost - gone:.2f} s after it was killed")
        reported = monitor.wait(
            lambda: next(
                (
                    t
                    for t, rows in _messages(monitor, "/diagnostics", gone)
                    if any("racc_observer_second" in r[0] and r[1] == 2 for r in rows)
                ),
                None,
            ),
            5,
        )
        assert reported is not None, "the host's loss is not on /diagnostics"
    finally:
        robot.close()


def _is_talker(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return b"__name:=talker" in f.read()
    except OSError:
        return False
