"""One live-test harness for ROS 1 and ROS 2: the tests of tests/live/ are written once and
run over both versions, as lark's own tests run one suite over every parser configuration.

A :class:`Ros` says what differs between the versions: the environment (a roscore on a free
port, or a ROS 2 domain of this run with discovery on this host), the racc ROS package,
the demo robot's launch file, and how the compiled runtime is started (``roslaunch
observers.launch``; on ROS 2 the processes observers.launch.xml names, as ``ros2 launch``
would start them: nothing on PyPI runs a launch file).  :func:`live_robot` gives a
:class:`LiveRobot`: the compiled tedusar, the processes started (stopped by pid and process
group, never by name: ``soak_support.Processes``), and the runtime's topics as a monitor
process sees them (``soak_support.Watch``).

Where each version runs: the parameter of a version whose client library (rospy, rclpy) is
not importable here is deselected (tests/live/conftest.py), unless ``RACC_REQUIRE_ROS=1``
(ROS 1) or ``RACC_REQUIRE_ROS2=1`` (ROS 2) is set: then it runs and fails loudly.  .ci/run
runs tests/live in its ROS 1 venv and again in its ROS 2 venv.
"""

from __future__ import annotations

import importlib.util
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from soak_support import RACC, ROOT, Processes, Watch, free_port, start_watch

TEDUSAR = ROOT / "models" / "tedusar.ram"
FASTDDS_PROFILE = ROOT / "tests" / "ros2" / "fastdds_localhost.xml"
# The demo nodes whose presence in the graph says the demo robot is up.
DEMO_UP = frozenset({"jaguar_node", "imu_node", "hokuyo_node", "hector_mapping", "joy_node"})


# -- the versions ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Ros:
    version: int
    library: str  # the client library the version needs here
    tools: tuple[str, ...]  # programs it needs on PATH
    require: str  # the variable that makes a missing version a failure

    @property
    def id(self) -> str:
        return f"ros{self.version}"

    @property
    def flag(self) -> list[str]:
        """racc's option for this version (ROS 1 is the default)."""
        return ["--ros", "2"] if self.version == 2 else []

    @property
    def robot_launch(self) -> str:
        return "robot.launch.xml" if self.version == 2 else "robot.launch"

    def missing(self) -> str | None:
        """Why this version cannot run here (None: it can)."""
        if importlib.util.find_spec(self.library) is None:
            return f"{self.library} is not importable (see docs/runtime.md)"
        absent = [t for t in self.tools if shutil.which(t) is None]
        return f"{', '.join(absent)} not installed (.ci/run installs them)" if absent else None

    def required(self) -> bool:
        return os.environ.get(self.require) == "1"


ROS1 = Ros(1, "rospy", ("roscore", "roslaunch"), "RACC_REQUIRE_ROS")
ROS2 = Ros(2, "rclpy", (), "RACC_REQUIRE_ROS2")
VERSIONS = (ROS1, ROS2)


def runnable(ros: Ros) -> bool:
    """Whether the tests of this version are collected here: it can run, or it must."""
    return ros.missing() is None or ros.required()


def check_runnable(ros: Ros) -> None:
    """A version that must run (RACC_REQUIRE_ROS*) but cannot is a failure, with why."""
    why = ros.missing()
    if why is not None:
        raise RuntimeError(f"{ros.require}=1, but ROS {ros.version} cannot run here: {why}")


def environment(ros: Ros, tmp: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONUNBUFFERED"] = "1"
    env["RACC_SECRET_FILE"] = str(tmp / "racc_secret")  # the robot's racc secret (a test's)
    if ros.version == 1:
        env.update(
            ROS_MASTER_URI=f"http://127.0.0.1:{free_port()}",
            ROS_IP="127.0.0.1",
            ROS_HOME=str(tmp / "ros_home"),
            ROS_PACKAGE_PATH=str(tmp / "pkg"),
        )
    else:
        env.update(
            ROS_DOMAIN_ID=str(random.randint(1, 100)),  # a domain of this test
            ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
            ROS_LOG_DIR=str(tmp / "ros_log"),
            AMENT_PREFIX_PATH=str(tmp / "pkg"),
            # Fast DDS 2 reads the first name, later versions the second
            FASTRTPS_DEFAULT_PROFILES_FILE=str(FASTDDS_PROFILE),
            FASTDDS_DEFAULT_PROFILES_FILE=str(FASTDDS_PROFILE),
        )
    return env


def tedusar_for(ros: Ros, tmp: Path) -> Path:
    """tedusar with its qualitative relations (``relate``); on ROS 2 without the
    ``interval`` on the servo: the demo publishes tedusar_msgs/ServoState there as a
    stand-in type no observer can read (docs/runtime.md, "Known limits")."""
    path = tmp / "tedusar.ram"
    lines = TEDUSAR.read_text(encoding="utf-8").splitlines()
    if ros.version == 2:
        lines = [x for x in lines if not x.startswith("interval ")]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def start_roscore(procs: Processes, env: dict[str, str]) -> subprocess.Popen[bytes]:
    import rosgraph

    port = env["ROS_MASTER_URI"].rsplit(":", 1)[1]
    core = procs.start(["roscore", "-p", port], "roscore.log")
    deadline = time.time() + 30
    while not rosgraph.is_master_online(env["ROS_MASTER_URI"]) and time.time() < deadline:
        time.sleep(0.2)
    assert rosgraph.is_master_online(env["ROS_MASTER_URI"]), "roscore did not come up"
    return core


# -- the robot under test -------------------------------------------------------------------


@dataclass
class Demo:
    proc: subprocess.Popen[bytes]
    directory: Path
    epoch: float  # the demo's start: its fault times count from here
    board: int
    control: int


@dataclass
class LiveRobot:
    ros: Ros
    env: dict[str, str]
    tmp: Path
    procs: Processes
    watch: Watch
    model: Path
    build: Path
    atoms: int
    # The atoms of every observer but the qualitative ones (BiQObs): those give their first
    # verdict only after 10 s of slope history (docs/observers.md), the others within 5 s.
    quick_atoms: int

    def racc(self, *args: str, timeout: float = 120) -> None:
        subprocess.run([*RACC, *args], check=True, env=self.env, timeout=timeout)

    def start_demo(self, name: str, faults: Sequence[str] = (), board: int | None = None) -> Demo:
        """``racc demo`` of the test's tedusar into ``tmp/name``, its board simulator on
        free ports (the board port ``board`` if given)."""
        board, control = board or free_port(), free_port()
        args = [*RACC, "demo", *self.ros.flag, str(self.model), "-o", str(self.tmp / name)]
        args += ["--board-port", str(board), "--control-port", str(control)]
        for f in faults:
            args += ["--fault", f]
        epoch = time.time()
        proc = self.procs.start(args, f"{name}.log")
        return Demo(proc, self.tmp / name, epoch, board, control)

    def wait_demo(self, timeout: float = 60) -> float:
        """When the demo's nodes are in the graph (their start is slow on a loaded machine)."""
        watch = self.watch
        up = watch.wait(lambda: time.time() if watch.nodes >= DEMO_UP else None, timeout)
        assert up is not None, f"the demo's nodes did not come up: {sorted(watch.nodes)}"
        return up

    def launch_runtime(
        self,
        demo: Demo | None,
        board: bool = True,
        build: Path | None = None,
        log: str = "runtime",
        mode: str = "act",
    ) -> list[subprocess.Popen[bytes]]:
        """The compiled runtime (``build``, the test's by default) for ``demo``'s robot, its
        repair engine in ``mode`` (act, advise or dry-run)."""
        build = build or self.build
        arguments = {"repair_mode": mode}
        if demo is not None:
            arguments["robot_launch"] = str(demo.directory / self.ros.robot_launch)
            if board:
                arguments["board"] = f"127.0.0.1:{demo.board}"
        if self.ros.version == 1:
            args = ["roslaunch", str(build / "observers.launch")]
            return [self.procs.start(args + [f"{k}:={v}" for k, v in arguments.items()], log)]
        from rac.ros2.launch import command_line, load_launch

        entries = load_launch(build / "observers.launch.xml", arguments)
        assert {e.executable for e in entries} >= {"observe", "engine", "repairer"}
        return [self.procs.start(command_line(e), f"{log}_{e.name}.log") for e in entries]

    def publish_text(self, topic: str, text: str) -> None:
        """One ``std_msgs/String`` on ``topic``, as an operator would send it (ROS 1:
        ``rostopic pub``; ROS 2, which has no CLI here: a few lines of rclpy), waiting for
        a subscriber first."""
        if self.ros.version == 1:
            command = ["rostopic", "pub", "-1", topic, "std_msgs/String", f"data: '{text}'"]
        else:
            command = [sys.executable, "-c", _RCLPY_PUBLISH, topic, text]
        subprocess.run(command, check=True, env=self.env, timeout=60, capture_output=True)

    def stop(self, *procs: subprocess.Popen[bytes]) -> None:
        """SIGINT (roslaunch ends its nodes), SIGKILL of the group after 20 s."""
        for proc in procs:
            self.procs.stop(proc)

    def stop_scene(self, demo: Demo, runtime: Sequence[subprocess.Popen[bytes]]) -> None:
        """A test's end: its runtime, its demo, then the nodes the repair engine started."""
        self.stop(*runtime)
        self.stop(demo.proc)
        self.stop_started()

    def stop_started(self) -> None:
        """Stop the nodes the repair engine started: they belong to the robot and outlive
        racc (docs/runtime.md), so the test stops them by the pid /repair_log gives."""
        for pid in started_pids(self.watch):
            stop_session(pid)


_RCLPY_PUBLISH = """
import sys, time
import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("racc_test_operator")
pub = node.create_publisher(String, sys.argv[1], 5)
deadline = time.time() + 20
while pub.get_subscription_count() == 0 and time.time() < deadline:
    rclpy.spin_once(node, timeout_sec=0.1)
assert pub.get_subscription_count() > 0, "nobody subscribes " + sys.argv[1]
pub.publish(String(data=sys.argv[2]))
end = time.time() + 1.0
while time.time() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
node.destroy_node()
rclpy.shutdown()
"""


@contextmanager
def live_robot(ros: Ros, tmp: Path) -> Iterator[LiveRobot]:
    """The environment of ``ros`` in ``tmp`` (a roscore of its own on ROS 1), racc's ROS
    package, tedusar compiled and the monitor subscribed; everything stopped after."""
    from rac.load.files import load_observers

    check_runnable(ros)
    env = environment(ros, tmp)
    # This process reads launch files with the same paths (rac.ros2.launch) and talks to
    # the same master or domain as its children.
    saved = dict(os.environ)
    os.environ.update(
        {k: v for k, v in env.items() if k.startswith(("ROS_", "AMENT", "FAST", "RACC_"))}
    )
    procs = Processes(env, tmp)
    try:
        subprocess.run(
            [*RACC, "ros-package", *ros.flag, "-o", str(tmp / "pkg"), "-q"], check=True, env=env
        )
        model, build = tedusar_for(ros, tmp), tmp / "build"
        subprocess.run(
            [*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"], check=True, env=env
        )
        specs = load_observers(build / "observers.yaml")[1]
        quick = sum(len(s.atoms) for s in specs if s.kind != "BiQObs")
        if ros.version == 1:
            start_roscore(procs, env)
        watch = start_watch(procs, ros.id)
        robot = LiveRobot(
            ros, env, tmp, procs, watch, model, build, sum(len(s.atoms) for s in specs), quick
        )
        try:
            yield robot
        finally:
            robot.stop_started()
    finally:
        procs.stop_all()  # roscore last: it was started first
        os.environ.clear()
        os.environ.update(saved)


# -- what the runtime said (and soak_support's all_ok_since, named_since) -------------------

Check = Callable[[], "float | None"]


def observed_since(watch: Watch, after: float, literal: str) -> Check:
    """When ``literal`` was first observed (level 0) after ``after``."""

    def check() -> float | None:
        for t, rows in watch.observations:
            if t >= after and (literal, 0) in rows:
                return t
        return None

    return check


def everything_observed(watch: Watch, after: float, atoms: int) -> Check:
    """When an observation set with every atom came (ok or not: under load a rate observer
    may flicker, which the repair engine's confirmation time rides out)."""

    def check() -> float | None:
        full = [t for t, rows in watch.observations if t >= after and len(rows) >= atoms]
        return full[0] if full else None

    return check


def logged(watch: Watch, after: float, action: str, target: str) -> bool:
    """The repair engine logged ``action`` on ``target`` done, after ``after``."""
    with watch.lock:
        return any(
            t >= after and name == action and hw == target and msg.startswith("done")
            for t, name, hw, _, msg in watch.repair_log
        )


def started_pids(watch: Watch, target: str | None = None) -> list[int]:
    """The pids of the nodes the repair engine started, from its start_node lines."""
    with watch.lock:
        return [
            int(m.group(1))
            for _, action, hw, _, msg in watch.repair_log
            if action == "start_node" and (target is None or hw == target)
            for m in [re.search(r"started detached as pid (\d+)", msg)]
            if m
        ]


def not_matched(watch: Watch, epoch: float) -> list[tuple[float, str]]:
    """The qualitative relations seen unmatched (time from ``epoch``), for the log."""
    with watch.lock:
        return [
            (round(t - epoch, 1), m)
            for t, rows in watch.observations
            for m, level in rows
            if level and m.startswith("not_matched")
        ]


# -- processes ------------------------------------------------------------------------------


def placed_build(robot: LiveRobot) -> Path:
    """tedusar placed on one declared machine ``base`` (127.0.0.1), compiled beside the
    test's build: its observer host then runs that machine's racc agent."""
    model = robot.tmp / "tedusar_base.ram"
    lines = robot.model.read_text(encoding="utf-8").splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("robot "))
    lines.insert(at + 1, "machine base address 127.0.0.1")
    model.write_text("\n".join(lines) + "\n", encoding="utf-8")
    build = robot.tmp / "build_base"
    robot.racc("compile", str(model), "-o", str(build), "--no-svg", "-q")
    return build


def kill_node(ros: int, node: str) -> float:
    """``kill -9`` of a demo node's process (its body, which getPid shows, ends with it):
    the outermost process whose command line names the node; when."""
    import psutil

    marker = f"__name:={node}" if ros == 1 else f"__node:={node}"
    found = [p for p in psutil.process_iter(["cmdline"]) if marker in (p.info["cmdline"] or [])]
    outer = [p for p in found if all(p.ppid() != q.pid for q in found)]
    assert outer, f"no process of {node}"
    now = time.time()
    for proc in outer:
        proc.kill()
    return now


def pid_alive(pid: int) -> bool:
    import psutil

    try:
        return bool(psutil.Process(pid).status() != psutil.STATUS_ZOMBIE)
    except psutil.Error:
        return False


def stop_session(pid: int) -> None:
    """SIGINT to a started node's session (its pid is the session's), SIGKILL if it lasts."""
    for sig, wait in ((signal.SIGINT, 10.0), (signal.SIGKILL, 5.0)):
        if not pid_alive(pid):
            return
        try:
            os.killpg(pid, sig)
        except OSError:
            return
        deadline = time.time() + wait
        while time.time() < deadline and pid_alive(pid):
            time.sleep(0.1)


def wait_for_text(path: Path, text: str, timeout: float, after: int = 0) -> int | None:
    """The offset in ``path`` just past ``text`` (searched from ``after``), or None: a
    process's log line, waited for."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        found = path.read_text(errors="replace").find(text, after) if path.exists() else -1
        if found >= 0:
            return found + len(text)
        time.sleep(0.2)
    return None
