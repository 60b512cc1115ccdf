"""A real ROS 1 graph that racc did not write, for the live tests of test_real_graph.py and
for ``bench/soak.py``: a roscore on a free port, ``robot.launch`` (from robot.launch.in:
Debian's ``rosbag play --loop`` of the two public bags, topic_tools relay and throttle,
robot_state_publisher with pr2_subset.urdf) and racc's runtime compiled from
``real_graph.ram`` (or any model given, such as one learned by ``racc record`` and ``racc
learn`` from this graph).

Everything is started through ``soak_support.Processes`` (a process group each, stopped by
SIGINT then SIGKILL of the group).  The nodes the repairer restarted may outlive the
runtime's roslaunch, so before roscore goes, every node still registered with this
roscore (ours alone: its port is ours) is killed by the pid it reports.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import cast

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # tests/: soak_support (bench/soak.py imports us too)

from soak_support import (  # noqa: E402
    RACC,
    ROOT,
    Processes,
    Watch,
    all_ok_since,
    compile_model,
    free_port,
    kill_pid,
    racc_learn,
    start_watch,
)

MODEL = HERE / "real_graph.ram"
URDF = HERE / "pr2_subset.urdf"
LAUNCH_TEMPLATE = HERE / "robot.launch.in"
BAGS = ("jackal_imu_odom.bag", "pr2_joint_states_roslib_header.bag")
# The graph's nodes (robot.launch's names) and, for the faults, which topic each feeds.
NODES = ("jackal_player", "pr2_player", "imu_relay", "odom_throttle", "robot_state_publisher")


def data_dir() -> Path:
    """The real bags: ../shared/data from the project root, else /work/shared/data."""
    for candidate in (ROOT.parent / "shared" / "data", Path("/work/shared/data")):
        if all((candidate / bag).is_file() for bag in BAGS):
            return candidate
    raise FileNotFoundError(f"{BAGS} not found in ../shared/data nor /work/shared/data")


def write_robot_launch(directory: Path) -> Path:
    text = LAUNCH_TEMPLATE.read_text(encoding="utf-8")
    text = text.replace("@DATA@", str(data_dir())).replace("@URDF@", str(URDF))
    path = directory / "robot.launch"
    path.write_text(text, encoding="utf-8")
    return path


@dataclass
class Graph:
    """One roscore with its environment, the compiled model and the runtime's topics."""

    env: dict[str, str]
    tmp: Path
    procs: Processes
    watch: Watch
    build: Path
    atoms: int
    robot_launch: Path

    def start_robot(self, log: str = "robot.log") -> subprocess.Popen[bytes]:
        return self.procs.start(["roslaunch", str(self.robot_launch)], log)

    def start_runtime(
        self, log: str = "runtime.log", robot_launch: Path | None = None, *args: str
    ) -> subprocess.Popen[bytes]:
        """``roslaunch observers.launch robot_launch:=...`` (this graph's by default)."""
        return self.procs.start(
            [
                "roslaunch",
                str(self.build / "observers.launch"),
                f"robot_launch:={robot_launch or self.robot_launch}",
                *args,
            ],
            log,
        )

    def use_model(self, model: Path, name: str) -> None:
        """Compile another model (a learned one) for the next ``start_runtime``."""
        self.build = self.tmp / name
        self.atoms = compile_model(model, self.build, self.env)

    def node_pid(self, node: str) -> int | None:
        """The pid a node reports (its XML-RPC getPid), as `rosnode info` finds it."""
        import rosgraph

        try:
            uri = rosgraph.Master("/racc_soak", master_uri=self.env["ROS_MASTER_URI"]).lookupNode(
                "/" + node
            )
            # ROS's slave API answers (code, status message, pid)
            reply = xmlrpc.client.ServerProxy(uri).getPid("/racc_soak")
            code, _, pid = cast("tuple[int, str, int]", reply)
        except Exception:  # not registered, or its XML-RPC server is gone or frozen
            return None
        return int(pid) if code == 1 else None

    def wait_nodes(self, nodes: tuple[str, ...], timeout: float) -> bool:
        deadline = time.time() + timeout
        while time.time() < deadline:
            if all(self.node_pid(n) is not None for n in nodes):
                return True
            time.sleep(0.3)
        return False

    def settle(self, target: str, timeout: float = 20.0) -> bool:
        """Before a fault: every observation ok (True), or else at least ``target`` running
        and named by no diagnosis (a graph whose observers flap never settles; the fault
        is then injected all the same, and a recovery bound fails)."""
        watch = self.watch
        if watch.wait(all_ok_since(watch, time.time(), self.atoms), timeout) is not None:
            return True
        print(f"\nnot every observation ok within {timeout:g} s before the fault")
        self.wait_nodes((target,), timeout)
        deadline = time.time() + timeout
        while time.time() < deadline:
            with watch.lock:
                last = watch.diagnosis[-1][1] if watch.diagnosis else []
            if not any(target in d.split(",") for d in last):
                break
            time.sleep(0.2)
        return False

    def registered_pids(self) -> list[int]:
        """The pids of every node registered with this roscore (ours: its port is ours)."""
        import rosgraph

        try:
            state = rosgraph.Master("/racc_soak", master_uri=self.env["ROS_MASTER_URI"])
            pubs, subs, srvs = state.getSystemState()
        except Exception:
            return []
        names = {n for _, nodes in (*pubs, *subs, *srvs) for n in nodes}
        # roscore's own rosout and the test's monitor end with their processes.
        names = {n for n in names if n != "/rosout" and not n.startswith("/racc_soak_monitor")}
        pids = [self.node_pid(n.lstrip("/")) for n in sorted(names)]
        return [p for p in pids if p is not None and p != os.getpid()]


@contextmanager
def real_graph(tmp: Path, model: Path = MODEL, robot_launch: Path | None = None) -> Iterator[Graph]:
    """A roscore on a free port with racc's ROS package and ``model`` compiled; the
    monitor subscribed.  The robot (``robot_launch``, by default this graph's) and the
    runtime are started by the caller."""
    port = free_port()
    env = dict(os.environ)
    env.update(
        ROS_MASTER_URI=f"http://127.0.0.1:{port}",
        ROS_IP="127.0.0.1",
        ROS_HOME=str(tmp / "ros_home"),
        ROS_PACKAGE_PATH=str(tmp / "pkg"),
        PYTHONUNBUFFERED="1",
    )
    subprocess.run([*RACC, "ros-package", "-o", str(tmp / "pkg"), "-q"], check=True, env=env)
    atoms = compile_model(model, tmp / "build", env)
    procs = Processes(env, tmp)
    core = procs.start(["roscore", "-p", str(port)], "roscore.log")
    graph: Graph | None = None
    try:
        import rosgraph

        deadline = time.time() + 30
        while not rosgraph.is_master_online(env["ROS_MASTER_URI"]) and time.time() < deadline:
            time.sleep(0.2)
        assert rosgraph.is_master_online(env["ROS_MASTER_URI"]), "roscore did not come up"
        watch = start_watch(procs, "ros1")
        launch = robot_launch or write_robot_launch(tmp)
        graph = Graph(env, tmp, procs, watch, tmp / "build", atoms, launch)
        yield graph
    finally:
        for proc in reversed(procs.procs):
            if proc is not core:
                procs.stop(proc)
        if graph is not None:
            for pid in graph.registered_pids():  # nodes the repairer left running
                kill_pid(pid)
        procs.stop(core)


def stop_robot_and_runtime(graph: Graph, *procs: subprocess.Popen[bytes]) -> None:
    """Stop the given launches, then any node they left registered (a restarted one)."""
    for proc in procs:
        graph.procs.stop(proc)
        graph.procs.procs.remove(proc)
    for pid in graph.registered_pids():
        kill_pid(pid)


def learn_model(
    graph: Graph, seconds: int, progress: Callable[[str], None] = lambda message: None
) -> Path:
    """``racc record`` of the graph for ``seconds``, then ``racc learn``: a model of it as a
    user would learn one (bench/soak.py --learn, test_real_graph_learned.py)."""
    robot = graph.start_robot("learn_robot.log")
    try:
        graph.wait_nodes(("jackal_player", "pr2_player", "robot_state_publisher"), 30)
        time.sleep(3.0)
        bag = graph.tmp / "learn.bag"
        progress(f"racc record for {seconds} s")
        subprocess.run(
            [*RACC, "record", "-o", str(bag), "--duration", str(seconds), "-q"],
            check=True,
            env=graph.env,
            timeout=seconds + 120,
        )
    finally:
        stop_robot_and_runtime(graph, robot)
    progress("racc learn")
    return racc_learn(bag, graph.tmp / "learn", graph.tmp / "learned.ram", graph.env)
