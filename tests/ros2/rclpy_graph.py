"""The relay graph of tests/ros1/relay_graph.py on ROS 2, made of rclpy nodes, for
``bench/live_scale.py --ros 2``.

The same shape: two chains of relays fed by players of the same two recordings (a
Jackal's 50 Hz IMU and odometry, a PR2's 100 Hz joint states), the same topic names and
node names, the same hand model, less robot_state_publisher and /tf (no ROS 2 build of it
here).  Each node is a process of its own (tests/ros2/rclpy_graph_nodes.py), an executable
of a package ``racc_relays`` in an ament prefix of the run, named by the launch XML
``relays_N.launch.xml`` that the repair engine restarts nodes from, as from a robot's.
PyPI has no ``ros2 launch``: the nodes are started here, each as ``ros2 launch`` would
(:func:`rac.ros2.launch.command_line`), and so is racc's runtime (``observers.launch.xml``).

Everything runs in a ROS domain of the run, discovery on this host only; what is started is
stopped by its process group, and the nodes racc restarted (detached, as a robot's nodes
are) by their pids, found by the run's own prefix on their command lines.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path

import psutil

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # tests/: soak_support
sys.path.insert(0, str(HERE.parent / "ros1"))  # relay_graph: the shape, the model

import relay_graph  # noqa: E402
from soak_support import (  # noqa: E402
    RACC,
    Processes,
    Watch,
    compile_model,
    kill_group,
    kill_pid,
    racc_learn,
    start_watch,
)

PACKAGE = "racc_relays"
NODES_MODULE = HERE / "rclpy_graph_nodes.py"
# Discovery of a hundred participants on this host alone (the file says why); Fast DDS's
# own announcement period (3 s), not the live tests' 0.5 s, which cost every idle relay of
# a hundred 1-2 % of a core.
PROFILE = HERE / "fastdds_many_localhost.xml"
PLAYER_BAGS = dict(zip(relay_graph.PLAYERS, relay_graph.BAGS, strict=True))
TYPES = {
    "sensor_msgs/Imu": "sensor_msgs/msg/Imu",
    "sensor_msgs/JointState": "sensor_msgs/msg/JointState",
}


def nodes(relays: int) -> list[str]:
    """Every node of the graph: the players and the relays."""
    return [*relay_graph.PLAYERS, *relay_graph.relay_nodes(relays)]


def options(divisor: int) -> relay_graph.ModelOptions:
    """The hand model's differences on ROS 2: no robot_state_publisher, the rates divided
    by ``divisor``, the memory of Python nodes (an rclpy relay's resident set is about
    100 MiB, a player's 150-350 MiB with its recording)."""
    return relay_graph.ModelOptions(
        state_publisher=False, divisor=divisor, player_mem_mb=512, relay_mem_mb=256
    )


def launch_text(relays: int, data: Path, divisor: int = 1) -> str:
    """The robot's ROS 2 launch XML; the players publish every ``divisor``-th message."""
    lines = ["<launch>"]
    for player, bag in PLAYER_BAGS.items():
        lines.append(
            f'  <node pkg="{PACKAGE}" exec="player" name="{player}" args="{data / bag} {divisor}"/>'
        )
    kinds = {prefix: TYPES[kind] for prefix, _, _, _, kind in relay_graph.CHAINS}
    for relay, source, target in relay_graph.chain_topics(relays):
        kind = kinds[relay.rsplit("_", 1)[0]]
        lines.append(
            f'  <node pkg="{PACKAGE}" exec="relay" name="{relay}" args="{source} {target} {kind}"/>'
        )
    return "\n".join([*lines, "</launch>", ""])


def write_prefix(prefix: Path) -> None:
    """An ament prefix with the package ``racc_relays``: its executables ``relay`` and
    ``player`` run this Python on tests/ros2/rclpy_graph_nodes.py."""
    index = prefix / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True, exist_ok=True)
    (index / PACKAGE).write_text("", encoding="utf-8")
    lib = prefix / "lib" / PACKAGE
    lib.mkdir(parents=True, exist_ok=True)
    for name in ("relay", "player"):
        script = lib / name
        script.write_text(
            f"#!{sys.executable}\n"
            "import runpy, sys\n"
            f"sys.argv[1:1] = [{name!r}]\n"
            f"runpy.run_path({str(NODES_MODULE)!r}, run_name='__main__')\n",
            encoding="utf-8",
        )
        script.chmod(0o755)


def write(directory: Path, relays: int, data: Path, divisor: int = 1) -> tuple[Path, Path]:
    """``relays_N.launch.xml`` and ``relays_N.ram`` in ``directory``."""
    launch = directory / f"relays_{relays}.launch.xml"
    launch.write_text(launch_text(relays, data, divisor), encoding="utf-8")
    model = directory / f"relays_{relays}.ram"
    model.write_text(relay_graph.model_text(relays, options(divisor)), encoding="utf-8")
    return launch, model


def mine(prefix: Path) -> list[psutil.Process]:
    """The graph's node processes, started here or by racc: their command lines hold the
    run's own prefix."""
    found = []
    for proc in psutil.process_iter(["cmdline"]):
        cmdline = proc.info["cmdline"] or []
        if any(str(prefix) in part for part in cmdline[:2]):
            found.append(proc)
    return found


def node_of(proc: psutil.Process) -> str | None:
    try:
        cmdline = proc.cmdline()
    except psutil.Error:
        return None
    return next((a.split(":=", 1)[1] for a in cmdline if a.startswith("__node:=")), None)


@dataclass
class Graph2:
    """One ROS domain with the relay graph's prefix, the compiled model and the monitor."""

    env: dict[str, str]
    tmp: Path
    procs: Processes
    watch: Watch
    build: Path
    atoms: int
    robot_launch: Path
    prefix: Path
    runtime: list[subprocess.Popen[bytes]] = field(default_factory=list)

    def start_robot(self, log: str = "robot") -> list[subprocess.Popen[bytes]]:
        from rac.ros2.launch import command_line, load_launch

        return [
            self.procs.start(command_line(e), f"{log}_{e.name}.log")
            for e in load_launch(self.robot_launch)
        ]

    def start_runtime(self, log: str = "runtime") -> list[subprocess.Popen[bytes]]:
        """The processes ``observers.launch.xml`` names, for this graph's launch file."""
        from rac.ros2.launch import command_line, load_launch

        entries = load_launch(
            self.build / "observers.launch.xml", {"robot_launch": str(self.robot_launch)}
        )
        self.runtime = [self.procs.start(command_line(e), f"{log}_{e.name}.log") for e in entries]
        return self.runtime

    def robot_processes(self) -> list[psutil.Process]:
        return mine(self.prefix)

    def runtime_processes(self) -> list[psutil.Process]:
        out = []
        for proc in self.runtime:
            with suppress(psutil.Error):
                out.append(psutil.Process(proc.pid))
        return out

    def use_model(self, model: Path, name: str) -> None:
        """Compile another model (a learned one) for the next ``start_runtime``."""
        self.build = self.tmp / name
        self.atoms = compile_model(model, self.build, self.env)

    def node_pid(self, node: str) -> int | None:
        """The pid of the process named ``node`` (``__node:=node``), innermost first."""
        for proc in self.robot_processes():
            if node_of(proc) == node:
                return proc.pid
        return None

    def wait_nodes(self, names: tuple[str, ...], timeout: float) -> bool:
        """Until the graph shows every node of ``names`` (the monitor's view)."""
        watch = self.watch
        wanted = {n.lstrip("/") for n in names}
        up = watch.wait(
            lambda: time.time() if {n.lstrip("/") for n in watch.nodes} >= wanted else None,
            timeout,
        )
        return up is not None

    def stop(self, procs: list[subprocess.Popen[bytes]], grace: float = 10.0) -> None:
        """SIGINT to each, then SIGKILL to the groups of those still running after
        ``grace`` (all at once: a hundred nodes one after the other took minutes)."""
        for proc in procs:
            if proc.poll() is None:
                with suppress(OSError):
                    proc.send_signal(signal.SIGINT)
        deadline = time.time() + grace
        for proc in procs:
            with suppress(subprocess.TimeoutExpired):
                proc.wait(max(0.0, deadline - time.time()))
        for proc in procs:
            kill_group(proc.pid)
            with suppress(subprocess.TimeoutExpired):
                proc.wait(5)
            if proc in self.procs.procs:
                self.procs.procs.remove(proc)

    def stop_robot_and_runtime(self, robot: list[subprocess.Popen[bytes]]) -> None:
        """The runtime, the robot, then any node racc restarted (detached: its own
        session)."""
        self.stop(self.runtime)
        self.runtime = []
        self.stop(robot)
        for proc in self.robot_processes():
            kill_pid(proc.pid)


def environment(tmp: Path, prefix: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.update(
        PYTHONUNBUFFERED="1",
        RACC_SECRET_FILE=str(tmp / "racc_secret"),
        ROS_DOMAIN_ID=os.environ.get("ROS_DOMAIN_ID") or str(random.randint(1, 100)),
        ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET",
        ROS_LOG_DIR=str(tmp / "ros_log"),
        AMENT_PREFIX_PATH=os.pathsep.join([str(tmp / "pkg"), str(prefix)]),
        # Fast DDS 2 reads the first name, later versions the second
        FASTRTPS_DEFAULT_PROFILES_FILE=str(PROFILE),
        FASTDDS_DEFAULT_PROFILES_FILE=str(PROFILE),
    )
    return env


@contextmanager
def rclpy_graph(tmp: Path, relays: int, data: Path, divisor: int = 1) -> Iterator[Graph2]:
    """The graph's files in ``tmp``, racc's ROS 2 package, the hand model compiled and the
    monitor subscribed.  The robot and the runtime are started by the caller; whatever is
    left of them is stopped at the end."""
    prefix = tmp / "relays_prefix"
    write_prefix(prefix)
    launch, model = write(tmp, relays, data, divisor)
    env = environment(tmp, prefix)
    saved = dict(os.environ)
    # This process reads the launch files (rac.ros2.launch finds executables through
    # AMENT_PREFIX_PATH) and talks to the same domain as its children.
    os.environ.update({k: v for k, v in env.items() if k.startswith(("ROS_", "AMENT", "FAST"))})
    procs = Processes(env, tmp)
    graph: Graph2 | None = None
    try:
        subprocess.run(
            [*RACC, "ros-package", "--ros", "2", "-o", str(tmp / "pkg"), "-q"], check=True, env=env
        )
        atoms = compile_model(model, tmp / "build", env)
        watch = start_watch(procs, "ros2")
        graph = Graph2(env, tmp, procs, watch, tmp / "build", atoms, launch, prefix)
        yield graph
    finally:
        if graph is not None:
            graph.stop(list(reversed(procs.procs)))
        procs.stop_all()
        for proc in mine(prefix):
            kill_pid(proc.pid)
        os.environ.clear()
        os.environ.update(saved)


def learn_model(
    graph: Graph2, seconds: int, progress: Callable[[str], None] = lambda message: None
) -> Path:
    """``racc record --ros 2`` of the graph for ``seconds``, then ``racc learn``."""
    robot = graph.start_robot("learn_robot")
    try:
        graph.wait_nodes(tuple(nodes(2)), 60)
        time.sleep(3.0)
        record = graph.tmp / "learn"
        progress(f"racc record --ros 2 for {seconds} s")
        subprocess.run(
            [*RACC, "record", "--ros", "2", "-o", str(record), "--duration", str(seconds), "-q"],
            check=True,
            env=graph.env,
            timeout=seconds + 120,
        )
    finally:
        graph.stop_robot_and_runtime(robot)
    progress("racc learn")
    return racc_learn(record, record, graph.tmp / "learned.ram", graph.env)
