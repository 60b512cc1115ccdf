"""racc's runtime at a real robot's size: live relay graphs of 10 to 200 nodes, ROS 1 or 2.

    .venv-ros1/bin/python bench/live_scale.py                         # 10, 50, 100, 200 relays
    .venv-ros1/bin/python bench/live_scale.py --sizes 100 --seconds 60 --repeats 3
    .venv-ros1/bin/python bench/live_scale.py --sizes 10 --learn 30   # also a learned model
    .venv-ros1/bin/python bench/live_scale.py --sizes 100 --statistics  # the robot with
                                                                      # /enable_statistics on
    .venv-ros1/bin/python bench/live_scale.py --sizes 100 --use-statistics  # and racc
                                                 # taking topics from them (statistics:=auto)
    .venv-ros2/bin/python bench/live_scale.py --ros 2 --sizes 10,20   # rclpy relays
    .venv-ros2/bin/python bench/live_scale.py --ros 2 --sizes 50 --divisor 5

The graph (tests/ros1/relay_graph.py): Debian's C++ ``topic_tools/relay`` nodes in two
chains, fed by ``rosbag play --loop`` of a Jackal's 50 Hz IMU and a PR2's 100 Hz joint
states, and robot_state_publisher; the hand model says each topic's rate, each relay's
output from its input and each node's limits.  A roscore on a free port; everything started
is stopped by its process group.  With ``--ros 2`` (tests/ros2/rclpy_graph.py) the same
shape of rclpy nodes, a process each, in a ROS domain of the run: an rclpy relay costs
about ten times a C++ one (rclpy's executor: 4-9 % of a core at 50-100 Hz here), so that on
a 2-core machine the robot alone fills the cores from about 20 relays at the recordings'
rates; ``--divisor N`` has the players publish every N-th message and the model expect
rates N times lower.

Per size and model: the robot is launched, then racc's runtime (``observers.launch``);
once every observation is ok, CPU and memory are read from each process's own counters
(psutil: CPU seconds over the healthy period, so the figures do not depend on what else
the machine runs, only on how fast its cores are) for --seconds of healthy running, in
which every repair plan and every diagnosis episode is false.  The observer host's own
report on /diagnostics gives the messages it received and its CPU per message (whole
process, and the receiving thread alone: the per-message path).  Then ``kill -9`` of the
relay in the middle of the IMU chain (``imu_relay_25`` of 100): the time to a diagnosis
naming it, to its restart done, and the first plan's target (the right node first).
The machine's load average is printed before and after each measurement: the machine is
shared, and wall-clock figures (latencies) move with it.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "ros1"))
sys.path.insert(0, str(ROOT / "tests" / "ros2"))

import rclpy_graph  # noqa: E402
import relay_graph  # noqa: E402
from rclpy_graph import Graph2  # noqa: E402
from real_graph import Graph, data_dir, learn_model, real_graph, stop_robot_and_runtime  # noqa: E402
from soak_support import (  # noqa: E402
    all_ok_since,
    episodes,
    flips,
    logged_done,
    named_since,
    plans,
)


@dataclass
class Usage:
    """CPU (% of one core over the period) and memory (MiB) of a set of processes."""

    cpu: float
    rss: float
    pss: float
    uss: float
    processes: int


@dataclass
class Figures:
    relays: int
    model: str
    load_before: float
    settled: float | None = None
    robot: Usage | None = None
    racc: Usage | None = None
    racc_each: dict[str, Usage] = field(default_factory=dict)
    host_report: str = ""
    plans: int = 0
    episodes: int = 0
    flipped: int = 0
    detected: float | None = None
    repaired: float | None = None
    first_plan: str = ""
    load_after: float = 0.0
    atoms: int = 0
    why: list[str] = field(default_factory=list)  # the healthy period's plans, episodes, flips


def processes(root: int) -> list[psutil.Process]:
    """The processes a launch started (its children, not roslaunch itself)."""
    try:
        return psutil.Process(root).children(recursive=True)
    except psutil.Error:
        return []


def cpu_seconds(procs: list[psutil.Process]) -> dict[int, float]:
    out = {}
    for p in procs:
        try:
            t = p.cpu_times()
            out[p.pid] = t.user + t.system
        except psutil.Error:
            pass
    return out


def usage(procs: list[psutil.Process], before: dict[int, float], seconds: float) -> Usage:
    after = cpu_seconds(procs)
    cpu = sum(after[p] - before[p] for p in after if p in before) / seconds * 100
    rss = pss = uss = 0.0
    for p in procs:
        try:
            info = p.memory_full_info()
            rss += info.rss
            pss += info.pss
            uss += info.uss
        except psutil.Error:
            pass
    return Usage(cpu, rss / 2**20, pss / 2**20, uss / 2**20, len(after))


def racc_name(proc: psutil.Process) -> str:
    try:
        cmd = " ".join(proc.cmdline())
    except psutil.Error:
        return "?"
    for name in ("observe", "engine", "repairer", "board_client"):
        if any(f"/racc/{d}{name}" in cmd for d in ("scripts/", "")) or f" {name} " in cmd:
            return name
    return cmd[:40]


class Run:
    """The robot and racc's runtime of one measurement, on either ROS version."""

    def __init__(self, graph: Graph | Graph2) -> None:
        self.graph = graph
        self.robot: list[subprocess.Popen[bytes]] = []
        self.runtime: list[subprocess.Popen[bytes]] = []

    def start_robot(self) -> None:
        graph = self.graph
        self.robot = graph.start_robot() if isinstance(graph, Graph2) else [graph.start_robot()]

    def start_runtime(self) -> None:
        graph = self.graph
        if isinstance(graph, Graph2):
            self.runtime = graph.start_runtime()
        else:
            self.runtime = [graph.start_runtime("runtime.log", None, *RUNTIME_ARGS)]

    def nodes(self, relays: int) -> list[str]:
        if isinstance(self.graph, Graph2):
            return rclpy_graph.nodes(relays)
        return relay_graph.nodes(relays)

    def robot_processes(self) -> list[psutil.Process]:
        if isinstance(self.graph, Graph2):
            return self.graph.robot_processes()
        return processes(self.robot[0].pid)

    def racc_processes(self) -> list[psutil.Process]:
        if isinstance(self.graph, Graph2):
            return self.graph.runtime_processes()
        return processes(self.runtime[0].pid)

    def stop(self) -> None:
        if isinstance(self.graph, Graph2):
            self.graph.stop_robot_and_runtime(self.robot)
        else:
            stop_robot_and_runtime(self.graph, *self.robot, *self.runtime)


def measure(graph: Graph | Graph2, relays: int, model: str, seconds: float) -> Figures:
    figures = Figures(relays, model, os.getloadavg()[0], atoms=graph.atoms)
    launched = time.time()
    run = Run(graph)
    run.start_robot()
    try:
        if not graph.wait_nodes(tuple(run.nodes(relays)), 30 + relays):
            progress("not every node of the robot registered; measuring all the same")
        run.start_runtime()
        ok = graph.watch.wait(all_ok_since(graph.watch, launched, graph.atoms), 60 + relays / 2)
        figures.settled = None if ok is None else ok - launched
        time.sleep(5.0)
        robot_procs, racc_procs = run.robot_processes(), run.racc_processes()
        robot_before, racc_before = cpu_seconds(robot_procs), cpu_seconds(racc_procs)
        start = time.time()
        progress(f"{relays} relays, {model}: healthy for {seconds:g} s")
        time.sleep(seconds)
        end = time.time()
        figures.robot = usage(robot_procs, robot_before, end - start)
        figures.racc = usage(racc_procs, racc_before, end - start)
        for proc in racc_procs:
            if proc.pid in racc_before:
                figures.racc_each[racc_name(proc)] = usage([proc], racc_before, end - start)
        made = [r for r in plans(graph.watch, start, end) if r[1] == "plan"]
        figures.plans = len(made)
        found = episodes(graph.watch, start, end)
        figures.episodes = len(found)
        flipped = flips(graph.watch, start, end)
        figures.flipped = sum(flipped.values())
        figures.why = [f"plan at +{r[0] - start:.1f} s: {r[4]}" for r in made]
        figures.why += [f"episode at +{t - start:.1f} s: {' | '.join(d)}" for t, d in found]
        figures.why += [f"turned negative {n}x: {m}" for m, n in sorted(flipped.items())]
        with graph.watch.lock:
            reports = [m for t, n, _, m in graph.watch.statuses if n.endswith(": load")]
        figures.host_report = reports[-1] if reports else "(no report)"
        crash(graph, relays, figures)
    finally:
        run.stop()
    figures.load_after = os.getloadavg()[0]
    return figures


def crash(graph: Graph | Graph2, relays: int, figures: Figures) -> None:
    """``kill -9`` of the relay in the middle of the IMU chain."""
    target = f"imu_relay_{max(1, relay_graph.chain_length(relays) // 2)}"
    pid = graph.node_pid(target)
    if pid is None:
        progress(f"{target} is not running: no crash")
        return
    progress(f"kill -9 {target}")
    at = time.time()
    os.kill(pid, signal.SIGKILL)
    named = graph.watch.wait(named_since(graph.watch, at, target), 20)
    done = graph.watch.wait(lambda: logged_done(graph.watch, at, "start_node", target), 30)
    figures.detected = None if named is None else named - at
    figures.repaired = None if done is None else done - at
    first = [msg for t, name, _, _, msg in graph.watch.since(at) if name == "plan"]
    found = re.search(r"repairing (\S+) with", first[0]) if first else None
    figures.first_plan = found.group(1) if found else "(none)"


def show(usage: Usage | None) -> str:
    if usage is None:
        return "-"
    return f"{usage.cpu:5.1f} % {usage.rss:5.0f}/{usage.pss:4.0f}/{usage.uss:4.0f} MiB"


def fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def report(all_figures: list[Figures], argv: list[str]) -> None:
    print(
        "\nCPU in % of one core over the healthy period (psutil, each process's own counters);"
        " memory RSS/PSS/USS summed; latencies in s from the kill"
    )
    print(
        f"{'relays':>6} {'model':<8} {'atoms':>5} {'settled':>7} {'robot cpu, rss/pss/uss':>26} "
        f"{'racc cpu, rss/pss/uss':>26} {'plans':>5} {'episodes':>8} {'flips':>5} "
        f"{'named':>6} {'repaired':>8} {'first plan':<14} load"
    )
    for f in all_figures:
        print(
            f"{f.relays:>6} {f.model:<8} {f.atoms:>5} {fmt(f.settled):>7} {show(f.robot):>26} "
            f"{show(f.racc):>26} {f.plans:>5} {f.episodes:>8} {f.flipped:>5} "
            f"{fmt(f.detected):>6} {fmt(f.repaired):>8} {f.first_plan:<14} "
            f"{f.load_before:.1f}-{f.load_after:.1f}"
        )
        for name, each in sorted(f.racc_each.items()):
            print(f"{'':>14} racc {name:<10} {show(each)}")
        print(f"{'':>14} observer host: {f.host_report}")
        for line in f.why:
            print(f"{'':>14} {line}")
    detected = [f.detected for f in all_figures if f.detected is not None]
    if detected:
        print(f"\ncrash to diagnosis: median {statistics.median(detected):.2f} s")
    print("\nreproduce:")
    print(f"  {os.path.relpath(sys.executable, ROOT)} bench/live_scale.py {' '.join(argv)}")


QUIET = False
RUNTIME_ARGS: list[str] = []  # observers.launch's arguments


@contextmanager
def graph_of(args: argparse.Namespace, tmp: Path, relays: int) -> Iterator[Graph | Graph2]:
    """The graph of ``relays`` relays on the ROS version asked for."""
    if args.ros == 2:
        with rclpy_graph.rclpy_graph(tmp, relays, data_dir(), args.divisor) as graph2:
            yield graph2
        return
    launch, model = relay_graph.write(tmp, relays, data_dir(), args.statistics)
    with real_graph(tmp, model, launch) as graph:
        yield graph


def progress(message: str) -> None:
    if not QUIET:
        print(f"[{time.strftime('%H:%M:%S')}] {message}", file=sys.stderr, flush=True)


def main() -> None:
    global QUIET
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--sizes", default="10,50,100,200", help="relays per graph (default 10,50,100,200)"
    )
    parser.add_argument(
        "--seconds", type=float, default=60.0, help="healthy period per run (default 60)"
    )
    parser.add_argument("--repeats", type=int, default=1, help="runs per size (default 1)")
    parser.add_argument(
        "--learn",
        type=int,
        default=0,
        metavar="S",
        help="also a model learned by racc record (S s) and racc learn (default 0: none)",
    )
    parser.add_argument(
        "--statistics",
        action="store_true",
        help="launch the robot with roscpp's topic statistics on (default: off)",
    )
    parser.add_argument(
        "--use-statistics",
        action="store_true",
        help="--statistics, and racc's observer host takes the topics it can from them "
        "(observers.launch statistics:=auto; default: it receives every topic)",
    )
    parser.add_argument(
        "--ros", type=int, choices=(1, 2), default=1, help="ROS version (default 1)"
    )
    parser.add_argument(
        "--divisor",
        type=int,
        default=1,
        metavar="N",
        help="ROS 2: the players publish every N-th message, the model's rates N times "
        "lower (default 1)",
    )
    parser.add_argument("-q", action="store_true", help="no progress lines (default: shown)")
    args = parser.parse_args()
    QUIET = args.q or not sys.stderr.isatty()
    if args.use_statistics:
        args.statistics = True
        RUNTIME_ARGS.append("statistics:=auto")
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(1))
    results: list[Figures] = []
    if args.ros == 2 and (args.statistics or args.use_statistics):
        parser.error("--statistics and --use-statistics are roscpp's (ROS 1)")
    if args.divisor < 1 or 100 % args.divisor:
        parser.error("--divisor must divide 100 (the joint states' rate): 1, 2, 5, 10, ...")
    try:
        for relays in [int(x) for x in args.sizes.split(",") if x]:
            with (
                tempfile.TemporaryDirectory(prefix=f"racc_scale{relays}_") as tmp,
                graph_of(args, Path(tmp), relays) as graph,
            ):
                for _ in range(args.repeats):
                    results.append(measure(graph, relays, "hand", args.seconds))
                if args.learn:
                    progress(f"{relays} relays: racc record {args.learn} s, racc learn")
                    if isinstance(graph, Graph2):
                        learned = rclpy_graph.learn_model(graph, args.learn, progress)
                    else:
                        learned = learn_model(graph, args.learn, progress)
                    graph.use_model(learned, "learned_build")
                    results.append(measure(graph, relays, "learned", args.seconds))
    finally:
        report(results, sys.argv[1:])


if __name__ == "__main__":
    main()
