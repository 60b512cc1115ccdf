"""Processes of the live placement tests (containers, second hosts): started, watched line
by line with the time each line came, and stopped by PID (never by name)."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RACC = [sys.executable, "-m", "rac"]

CHAT_MODEL = """robot chat
topic /chatter : std_msgs/String @ 10 Hz
node talker {
  publishes /chatter
  limits cpu 90 %, mem 900 MB
}
"""

# The chat robot's nodes and a monitor of the runtime's topics (JSON lines: t, topic, rows of
# name, level, message, hardware_id, values), per ROS version.  On ROS 1 the monitor reads
# /diagnostics too; on ROS 2 it subscribes transient-local, which /diagnostics (volatile)
# does not match.
TALKER = {
    1: """import rospy
from std_msgs.msg import String
rospy.init_node("talker")
pub = rospy.Publisher("/chatter", String, queue_size=10)
rate = rospy.Rate(10)
while not rospy.is_shutdown():
    pub.publish(String(data="hello"))
    rate.sleep()
""",
    2: """import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("talker")
pub = node.create_publisher(String, "/chatter", 10)
node.create_timer(0.1, lambda: pub.publish(String(data="hello")))
rclpy.spin(node)
""",
}

LISTENER = {
    1: """import rospy
from std_msgs.msg import String
rospy.init_node("listener")
rospy.Subscriber("/chatter", String, lambda m: None)
rospy.spin()
""",
    2: """import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("listener")
node.create_subscription(String, "/chatter", lambda m: None, 10)
rclpy.spin(node)
""",
}

# The runtime's topics as JSON lines; on ROS 1 /diagnostics too (the host's loss is there).
MONITOR = {
    1: """import json, time, rospy
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
""",
    2: """import json, time, rclpy
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
""",
}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def chat_model(tmp: Path, text: str = CHAT_MODEL) -> Path:
    path = tmp / "chat.ram"
    path.write_text(text, encoding="utf-8")
    return path


def contained_argv(argv: Sequence[str]) -> list[str]:
    """``argv`` in its own PID namespace, as a container runs it (getPid answers 1)."""
    return ["unshare", "--pid", "--fork", "--mount-proc", *argv]


def stop(proc: subprocess.Popen[bytes], sig: int = signal.SIGINT) -> None:
    """SIGINT (roslaunch and rospy end their children), then SIGKILL; a process started in
    its own session loses its whole group."""
    if proc.poll() is None:
        try:
            if os.getpgid(proc.pid) == proc.pid:
                os.killpg(proc.pid, sig)
            else:
                proc.send_signal(sig)
            proc.wait(15)
        except (subprocess.TimeoutExpired, ProcessLookupError):
            pass
    if proc.poll() is None:
        try:
            if os.getpgid(proc.pid) == proc.pid:
                os.killpg(proc.pid, signal.SIGKILL)
            else:
                proc.kill()
        except ProcessLookupError:
            pass
        proc.wait(5)


class Watcher:
    """A process whose output lines are kept with the time each arrived."""

    def __init__(self, argv: Sequence[str], env: dict[str, str], log: Path | None = None) -> None:
        self.proc = subprocess.Popen(
            list(argv),
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        self.lines: list[tuple[float, str]] = []
        self.log = log
        self._lock = threading.Lock()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:
            line = raw.decode("utf-8", "replace").rstrip("\n")
            with self._lock:
                self.lines.append((time.time(), line))
            if self.log is not None:
                with open(self.log, "a", encoding="utf-8") as f:
                    f.write(line + "\n")

    def lines_since(self, t: float) -> list[tuple[float, str]]:
        with self._lock:
            return [(s, line) for s, line in self.lines if s >= t]

    def text(self) -> str:
        with self._lock:
            return "\n".join(line for _, line in self.lines)

    def wait(self, what: Callable[[], float | None], timeout: float) -> float | None:
        deadline = time.time() + timeout
        while time.time() < deadline:
            found = what()
            if found is not None:
                return found
            time.sleep(0.05)
        return None

    def wait_line(self, needle: str, timeout: float, since: float = 0.0) -> float | None:
        def found() -> float | None:
            hits = [t for t, line in self.lines_since(since) if needle in line]
            return hits[0] if hits else None

        return self.wait(found, timeout)


def start_roscore(port: int, env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    import rosgraph

    out = open(log, "wb")  # noqa: SIM115 - closed with the process
    core = subprocess.Popen(
        ["roscore", "-p", str(port)], env=env, stdout=out, stderr=subprocess.STDOUT
    )
    uri = env["ROS_MASTER_URI"]
    deadline = time.time() + 20
    while not rosgraph.is_master_online(uri) and time.time() < deadline:
        time.sleep(0.2)
    assert rosgraph.is_master_online(uri), "roscore did not come up"
    return core


def can_make_netns() -> bool:
    """``ip netns add`` works here (root, iproute2)."""
    if os.geteuid() != 0 or shutil.which("ip") is None:
        return False
    name = f"racc_probe{os.getpid()}"
    made = subprocess.run(["ip", "netns", "add", name], capture_output=True, check=False)
    if made.returncode != 0:
        return False
    subprocess.run(["ip", "netns", "del", name], capture_output=True, check=False)
    return True


class NetPair:
    """Two network namespaces joined by a veth pair: two "computers" on this one, at
    10.213.X.1 (``a``) and 10.213.X.2 (``b``).  Everything bound inside them is reachable
    only from them.  :meth:`close` kills what still runs in them (all started by the test)
    and deletes them, their veth pair with them."""

    def __init__(self) -> None:
        tag = f"{os.getpid() % 100000}"
        self.names = {"a": f"raccA{tag}", "b": f"raccB{tag}"}
        x = os.getpid() % 250 + 1
        self.addresses = {"a": f"10.213.{x}.1", "b": f"10.213.{x}.2"}
        self._made: list[str] = []

    def _ip(self, *args: str) -> None:
        subprocess.run(["ip", *args], check=True, capture_output=True)

    def open(self) -> NetPair:
        a, b = self.names["a"], self.names["b"]
        for ns in (a, b):
            self._ip("netns", "add", ns)
            self._made.append(ns)
            self._ip("-n", ns, "link", "set", "lo", "up")
        veth_a, veth_b = f"v{a[-9:]}", f"v{b[-9:]}"
        self._ip(
            "link", "add", veth_a, "netns", a, "type", "veth", "peer", "name", veth_b, "netns", b
        )
        for key, ns, dev in (("a", a, veth_a), ("b", b, veth_b)):
            self._ip("-n", ns, "addr", "add", f"{self.addresses[key]}/24", "dev", dev)
            self._ip("-n", ns, "link", "set", dev, "up")
            # DDS discovers by multicast: send it over the pair (it stays in the two).
            self._ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", dev)
        return self

    def argv(self, which: str, argv: Sequence[str]) -> list[str]:
        return ["ip", "netns", "exec", self.names[which], *argv]

    def pids(self, which: str) -> list[int]:
        done = subprocess.run(
            ["ip", "netns", "pids", self.names[which]], capture_output=True, text=True, check=False
        )
        return [int(p) for p in done.stdout.split()]

    def identify(self, pid: int) -> str:
        done = subprocess.run(
            ["ip", "netns", "identify", str(pid)], capture_output=True, text=True, check=False
        )
        return done.stdout.strip()

    def close(self) -> None:
        for ns in self._made:
            for _ in range(3):
                pids = self.pids("a" if ns == self.names["a"] else "b")
                if not pids:
                    break
                for pid in pids:
                    with contextlib.suppress(ProcessLookupError):
                        os.kill(pid, signal.SIGKILL)
                time.sleep(0.2)
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, check=False)
        self._made.clear()


def json_lines(watcher: Watcher, since: float = 0.0) -> list[dict[str, Any]]:
    """The JSON objects a monitor printed one a line (a line that another writer's output
    cut into is skipped)."""
    out = []
    for _, line in watcher.lines_since(since):
        start = line.find('{"t"')
        if start < 0:
            continue
        try:
            out.append(json.loads(line[start:]))
        except json.JSONDecodeError:
            continue
    return out


# -- the chat robot as a package and a launch file (tests of nodes racc restarts) ------------

# A talker and a listener: the robot whose talker racc restarts (tests/live/
# test_lifetime_live.py, tests/ros1/test_slow_node_live.py, bench/lifetime.py).
CHAT_PAIR_MODEL = """robot chat
topic /chatter : std_msgs/String @ 10 Hz
node talker {
  publishes /chatter
  limits cpu 90 %, mem 900 MB
}
node listener { subscribes /chatter }
"""

# The ROS 1 talker with a getPid that takes 1 s (racc's XML-RPC time-out is 0.5 s); its
# XML-RPC server runs a thread per request: the node itself is healthy, at 10 Hz.
SLOW_GETPID_S = 1.0
SLOW_GETPID_TALKER = f"""import time
from rospy.impl import masterslave
_answer = masterslave.ROSHandler.getPid
def _slow(self, caller_id):
    time.sleep({SLOW_GETPID_S})
    return _answer(self, caller_id)
masterslave.ROSHandler.getPid = _slow
""" + TALKER[1]


def topic_rows(monitor: Watcher, topic: str, since: float = 0.0) -> list[tuple[float, Any]]:
    """(time, rows) of each array a MONITOR printed for ``topic`` since ``since``."""
    return [(m["t"], m["rows"]) for m in json_lines(monitor, since) if m["topic"] == topic]


def can_unshare() -> bool:
    """``unshare --pid`` works here (root)."""
    if shutil.which("unshare") is None:
        return False
    done = subprocess.run(
        ["unshare", "--pid", "--fork", "--mount-proc", "true"], capture_output=True, check=False
    )
    return done.returncode == 0


PACKAGE_XML = (
    '<?xml version="1.0"?>\n<package format="2"><name>chat</name><version>0.0.0</version>'
    "<description>test</description><maintainer email='a@b.c'>a</maintainer>"
    "<license>MIT</license></package>\n"
)


def chat_package(root: Path, version: int, nodes: dict[str, str]) -> Path:
    """The package 'chat' with one executable per node (name -> Python source), under
    ``root``: a ROS 1 package folder (``root`` on ROS_PACKAGE_PATH), or a ROS 2 install
    prefix whose ament index lists it (``root`` on AMENT_PREFIX_PATH).  The folder of the
    executables."""
    if version == 2:
        index = root / "share" / "ament_index" / "resource_index" / "packages"
        index.mkdir(parents=True, exist_ok=True)
        (index / "chat").write_text("", encoding="utf-8")
        exe_dir = root / "lib" / "chat"
    else:
        exe_dir = root / "chat"
        exe_dir.mkdir(parents=True, exist_ok=True)
        (exe_dir / "package.xml").write_text(PACKAGE_XML, encoding="utf-8")
    exe_dir.mkdir(parents=True, exist_ok=True)
    for name, body in nodes.items():
        exe = exe_dir / name
        exe.write_text(f"#!{sys.executable}\n{body}", encoding="utf-8")
        exe.chmod(0o755)
    return exe_dir


def chat_launch(path: Path, version: int, names: Sequence[str]) -> Path:
    """A robot launch file starting each of ``names`` from the package 'chat'."""
    exe = "exec" if version == 2 else "type"
    lines = [f'  <node pkg="chat" {exe}="{n}" name="{n}"/>' for n in names]
    path.write_text("<launch>\n" + "\n".join(lines) + "\n</launch>\n", encoding="utf-8")
    return path


# ``ros2 launch FILE`` for tests: the PyPI wheels have no ros2 command.  It starts each
# <node> as racc's launch reader says ros2 launch would, and on SIGINT or SIGTERM passes
# SIGINT to every node and waits for them, as ros2 launch does.
ROS2_LAUNCH = """import signal, subprocess, sys, time
from rac.ros2.launch import command_line, load_launch
assert sys.argv[1] == "launch"
procs = [subprocess.Popen(command_line(n)) for n in load_launch(sys.argv[2])]
stopping = []
for sig in (signal.SIGINT, signal.SIGTERM):
    signal.signal(sig, lambda s, f: stopping.append(s))
while not stopping and any(p.poll() is None for p in procs):
    time.sleep(0.1)
for p in procs:
    if p.poll() is None:
        p.send_signal(signal.SIGINT)
for p in procs:
    try:
        p.wait(10)
    except subprocess.TimeoutExpired:
        p.kill()
"""


def ros2_launch_command(tmp: Path) -> Path:
    """An executable named ``ros2`` (of this Python) that runs ``ros2 launch FILE``."""
    folder = tmp / "ros2_standin"
    folder.mkdir(exist_ok=True)
    exe = folder / "ros2"
    exe.write_text(f"#!{sys.executable}\n{ROS2_LAUNCH}", encoding="utf-8")
    exe.chmod(0o755)
    return exe


def pids_naming(arg: str, within: Path | None = None) -> list[int]:
    """Live processes (not zombies) whose command line carries ``arg`` exactly (and, with
    ``within``, a path under that folder: a process of this test's own, not of another run
    on the machine with a node of the same name)."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/cmdline", "rb") as f:
                line = f.read().split(b"\0")
            with open(f"/proc/{entry}/stat", "rb") as f:
                state = f.read().rsplit(b")", 1)[1].split()[0]
        except OSError:
            continue
        mine = within is None or any(str(within).encode() in a for a in line)
        if arg.encode() in line and state not in (b"Z", b"X") and mine:
            out.append(int(entry))
    return out
