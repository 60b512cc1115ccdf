"""A ROS 2 robot on two computers (issue 28), without a second computer: two network
namespaces joined by a veth pair, ``base`` (the engine, the repairer, a listener) and
``second`` (a talker).  The talker's process is watched by the observer host of its
machine, its crash is diagnosed, and it is restarted there by that machine's racc agent
from the robot's launch XML file; when the second host goes, the engine reports it lost.

Needs root for ``ip netns`` (CI is root).  DDS discovers by multicast over the pair only
(the namespaces see nothing else); both are deleted at the end, with what runs in them.
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

if os.environ.get("RACC_REQUIRE_ROS2") == "1":
    import rclpy  # noqa: F401
else:
    pytest.importorskip("rclpy", reason="ROS 2 (rclpy) is not importable")

from live_procs import RACC, NetPair, Watcher, can_make_netns, json_lines, stop

if not can_make_netns():
    pytest.skip("ip netns needs root and iproute2 (CI runs as root)", allow_module_level=True)

FASTDDS_PROFILE = Path(__file__).with_name("fastdds_localhost.xml")

TALKER = """import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("talker")
pub = node.create_publisher(String, "/chatter", 10)
node.create_timer(0.1, lambda: pub.publish(String(data="hello")))
rclpy.spin(node)
"""

LISTENER = """import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("listener")
node.create_subscription(String, "/chatter", lambda m: None, 10)
rclpy.spin(node)
"""

MONITOR = """import json, time, rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
rclpy.init()
node = rclpy.create_node("racc_multihost_monitor")
qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
def show(topic):
    def cb(a):
        rows = [[s.name, s.level[0] if isinstance(s.level, bytes) else int(s.level), s.message,
                 s.hardware_id, {v.key: v.value for v in s.values}] for s in a.status]
        print(json.dumps({"t": time.time(), "topic": topic, "rows": rows}), flush=True)
    return cb
for topic in ("/observations", "/diagnosis", "/repair_log"):
    node.create_subscription(DiagnosticArray, topic, show(topic), qos)
rclpy.spin(node)
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
  <node pkg="chat" exec="talker" name="talker"/>
  <node pkg="chat" exec="listener" name="listener"/>
</launch>
"""


def _prefix(tmp: Path) -> Path:
    """An install prefix whose ament index lists the package 'chat' (talker, listener)."""
    prefix = tmp / "prefix"
    index = prefix / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / "chat").write_text("", encoding="utf-8")
    lib = prefix / "lib" / "chat"
    lib.mkdir(parents=True)
    for name, body in (("talker", TALKER), ("listener", LISTENER)):
        exe = lib / name
        exe.write_text(f"#!{sys.executable}\n{body}", encoding="utf-8")
        exe.chmod(0o755)
    return prefix


@pytest.fixture
def net() -> Iterator[NetPair]:
    pair = NetPair().open()
    try:
        yield pair
    finally:
        pair.close()


def _messages(monitor: Watcher, topic: str, since: float = 0.0) -> list[tuple[float, Any]]:
    return [(m["t"], m["rows"]) for m in json_lines(monitor, since) if m["topic"] == topic]


def _row(monitor: Watcher, name: str, since: float, level: int) -> float | None:
    for t, rows in _messages(monitor, "/observations", since):
        if any(r[0] == name and r[1] == level for r in rows):
            return float(t)
    return None


def test_a_node_on_a_second_host_is_observed_and_repaired_there(
    net: NetPair, tmp_path: Path
) -> None:
    model = tmp_path / "duo.ram"
    model.write_text(MODEL.format(a=net.addresses["a"], b=net.addresses["b"]), encoding="utf-8")
    (tmp_path / "robot.launch.xml").write_text(ROBOT_LAUNCH, encoding="utf-8")
    (tmp_path / "monitor.py").write_text(MONITOR, encoding="utf-8")
    build = tmp_path / "build"
    subprocess.run([*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"], check=True)
    prefix = _prefix(tmp_path)
    env = dict(os.environ)
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)  # the namespaces' subnet: the pair only
    env.update(
        ROS_DOMAIN_ID=str((os.getpid() + 71) % 100 + 1),
        ROS_LOG_DIR=str(tmp_path / "ros_log"),
        AMENT_PREFIX_PATH=str(prefix),
        PYTHONUNBUFFERED="1",
    )
    for variable in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
        env.setdefault(variable, str(FASTDDS_PROFILE))
    observers, launch = str(build / "observers.yaml"), str(tmp_path / "robot.launch.xml")
    watchers: list[Watcher] = []

    def start(where: str, argv: list[str], log: str) -> Watcher:
        w = Watcher(net.argv(where, argv), env, tmp_path / log)
        watchers.append(w)
        return w

    try:
        lib = prefix / "lib" / "chat"
        talker_argv = [str(lib / "talker"), "--ros-args", "-r", "__node:=talker"]
        talker = start("b", talker_argv, "talker.log")
        start("a", [str(lib / "listener"), "--ros-args", "-r", "__node:=listener"], "l.log")
        monitor = start("a", [sys.executable, str(tmp_path / "monitor.py")], "monitor.log")
        ros2 = ["--ros", "2"]
        second = start(
            "b",
            [*RACC, "observe", observers, "--machine", "second", "--launch", launch, *ros2],
            "observe_second.log",
        )
        start("a", [*RACC, "observe", observers, "--machine", "base", *ros2], "obs_base.log")
        engine = start("a", [*RACC, "engine", str(build / "model.yaml"), *ros2], "engine.log")
        repairer = start(
            "a",
            [
                *RACC,
                "repairer",
                str(build / "model.yaml"),
                "--launch",
                launch,
                "--machine",
                "base",
                *ros2,
            ],
            "repair.log",
        )

        def watched_there() -> float | None:
            for t, rows in _messages(monitor, "/observations"):
                for name, level, _, _, values in rows:
                    if (
                        name == "running(talker)"
                        and level == 0
                        and values.get("host") == "racc_observer_second"
                        and values.get("watched") == "process"
                    ):
                        return float(t)
            return None

        assert monitor.wait(watched_there, 60) is not None, second.text()
        assert monitor.wait(lambda: _row(monitor, "ok(chatter)", 0, 0), 20) is not None
        time.sleep(3.0)  # the repairer's agent publisher is matched

        crash = time.time()
        os.kill(talker.proc.pid, signal.SIGKILL)  # 'ip netns exec' execs: this is the talker
        down = monitor.wait(lambda: _row(monitor, "running(talker)", crash, 2), 10)
        assert down is not None, "the crash on the second host was not seen"

        def diagnosed() -> float | None:
            for t, rows in _messages(monitor, "/diagnosis", crash):
                if any("talker" in r[2].split(",") for r in rows):
                    return float(t)
            return None

        named = monitor.wait(diagnosed, 10)
        assert named is not None, "the crash on the second host was not diagnosed"
        done = second.wait_line("agent second: start_node(talker) done", 20, crash)
        assert done is not None, second.text() + "\n" + repairer.text()
        back = monitor.wait(lambda: _row(monitor, "running(talker)", named, 0), 30)
        assert back is not None, "the talker did not come back"
        # Restarted on the second machine: its new process is in that namespace.
        restarted = [p for p in net.pids("b") if p != talker.proc.pid and _is_talker(p)]
        assert restarted and all(net.identify(p) == net.names["b"] for p in restarted)
        assert not [p for p in net.pids("a") if _is_talker(p)]
        print(
            f"\nsecond host (ROS 2): not_running {down - crash:.2f} s, diagnosed "
            f"{named - crash:.2f} s, running again {back - crash:.2f} s after the kill"
        )
        assert down - crash <= 3.0 and named - crash <= 5.0

        # The second host goes: its atoms become unknown, and its loss is reported.
        gone = time.time()
        os.kill(second.proc.pid, signal.SIGKILL)
        lost = engine.wait_line("observer host racc_observer_second lost", 15, gone)
        assert lost is not None, engine.text()
        print(f"second host lost (ROS 2): reported {lost - gone:.2f} s after it was killed")
    finally:
        for w in reversed(watchers):
            stop(w.proc)


def _is_talker(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return b"__node:=talker" in f.read()
    except OSError:
        return False
