"""False alarms and repair latencies of racc's live runtime on a real ROS 1 graph.

    .venv-ros1/bin/python bench/soak.py                       # 0, 50, 90 % load, 120 s each
    .venv-ros1/bin/python bench/soak.py --seconds 300 --loads 0,70,90 --repeats 5
    .venv-ros1/bin/python bench/soak.py --learn 60            # also a model learned from it
    .venv-ros1/bin/python bench/soak.py --model learned.ram   # any model of this graph
    .venv-ros1/bin/python bench/soak.py --rates --loads 0,70,90 --seconds 40   # the graph alone

The graph (tests/ros1/real_graph.py): Debian's ``rosbag play --loop`` of a Jackal's IMU and
odometry (50 Hz) and of a PR2's joint states (100 Hz, bursty), topic_tools relay and
throttle, robot_state_publisher; the model is tests/ros1/real_graph.ram unless --model or
--learn says otherwise.  A roscore on a free port; everything started is stopped by its
process group.

Healthy soak, per load level: the robot and racc's runtime are launched together, and once
every observation is ok (or after --settle s) stress-ng loads both cores at the level for
--seconds; the repair plans and the diagnosis episodes (/diagnosis turning non-empty) in
that time are counted and given per hour, with the share of the time a diagnosis stood
(an episode under way when the soak starts counts).  Nothing is wrong with the graph, so
each is false.  ``--rates`` checks that: the topics' rates as a plain rospy subscriber
receives them, without racc, at each load.

Faults, --repeats each, on the healthy graph at no extra load: ``crash`` (SIGKILL of the
relay), ``freeze`` (SIGSTOP of the Jackal's bag player), ``rate`` (the throttle replaced by
a 3 Hz one under the same node name: the master shuts the old one down).  Detection: the
fault to a diagnosis naming the node; restart: to ``start_node`` done on /repair_log;
recovery: to every observation ok and /diagnosis empty again.  Medians over the repeats.
A value fault needs a publisher whose values can be changed; the bags' cannot, so none.
"""

from __future__ import annotations

import argparse
import itertools
import os
import shlex
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "ros1"))

from real_graph import (  # noqa: E402
    MODEL,
    NODES,
    Graph,
    learn_model,
    real_graph,
    stop_robot_and_runtime,
)
from soak_support import (  # noqa: E402
    all_ok_since,
    cpu_load,
    episodes,
    faulty_share,
    kill_pid,
    logged_done,
    named_since,
    plans,
)


@dataclass
class SoakFigures:
    model: str
    load: int
    seconds: float
    settled: float | None  # launch to every observation ok
    bring_up_plans: int
    plans: int
    actions: int
    episodes: int
    faulty: float  # share of the soak with a diagnosis standing
    detail: list[str] = field(default_factory=list)

    def per_hour(self, n: int) -> float:
        return n * 3600.0 / self.seconds


@dataclass
class FaultFigures:
    kind: str
    target: str
    detected: list[float] = field(default_factory=list)
    restarted: list[float] = field(default_factory=list)
    recovered: list[float] = field(default_factory=list)
    misses: int = 0
    unsettled: int = 0  # injections into a graph that was not all ok


def launch(
    graph: Graph, settle: float
) -> tuple[list[subprocess.Popen[bytes]], float, float | None]:
    launched = time.time()
    procs = [graph.start_robot(), graph.start_runtime()]
    ok = graph.watch.wait(all_ok_since(graph.watch, launched, graph.atoms), settle)
    return procs, launched, None if ok is None else ok - launched


def soak(graph: Graph, model: str, load: int, seconds: float, settle: float) -> SoakFigures:
    procs, launched, settled = launch(graph, settle)
    bring_up = len([r for r in plans(graph.watch, launched, time.time()) if r[1] == "plan"])
    try:
        with cpu_load(graph.procs, load):
            start = time.time()
            progress(f"{model}: {load} % load for {seconds:g} s")
            time.sleep(seconds)
            end = time.time()
    finally:
        stop_robot_and_runtime(graph, *procs)
    acted = plans(graph.watch, start, end)
    found = episodes(graph.watch, start, end)
    figures = SoakFigures(
        model,
        load,
        end - start,
        settled,
        bring_up,
        len([r for r in acted if r[1] == "plan"]),
        len(acted),
        len(found),
        faulty_share(graph.watch, start, end),
    )
    figures.detail = [
        f"{t - start:7.1f} s  plan: {msg}" for t, n, _, _, msg in acted if n == "plan"
    ]
    figures.detail += [f"{t - start:7.1f} s  diagnosis: {d}" for t, d in found]
    return figures


Injection = Callable[[Graph], Callable[[], None]]


def crash(graph: Graph) -> Callable[[], None]:
    pid = graph.node_pid("imu_relay")
    assert pid is not None, "imu_relay is not running"
    os.kill(pid, signal.SIGKILL)
    return lambda: None


def freeze(graph: Graph) -> Callable[[], None]:
    pid = graph.node_pid("jackal_player")
    assert pid is not None, "jackal_player is not running"
    os.kill(pid, signal.SIGSTOP)
    return lambda: kill_pid(pid)  # if the repairer left it frozen


def rate_drop(graph: Graph) -> Callable[[], None]:
    rogue = graph.procs.start(
        [
            "/usr/lib/topic_tools/throttle",
            "messages",
            "/jackal_velocity_controller/odom",
            "3",
            "/odom_throttled",
            "__name:=odom_throttle",
        ],
        "rate_drop.log",
    )

    def clean() -> None:
        graph.procs.stop(rogue, grace=3)
        graph.procs.procs.remove(rogue)

    return clean


FAULTS: dict[str, tuple[str, Injection]] = {
    "crash": ("imu_relay", crash),
    "freeze": ("jackal_player", freeze),
    "rate": ("odom_throttle", rate_drop),
}


def faults(
    graph: Graph, kinds: list[str], repeats: int, settle: float, results: list[FaultFigures]
) -> None:
    """Each kind ``repeats`` times on one running graph; figures appended to ``results``."""
    if not kinds:
        return
    procs, _, _ = launch(graph, settle)
    try:
        for kind in kinds:
            target, inject = FAULTS[kind]
            figures = FaultFigures(kind, target)
            results.append(figures)
            for i in range(repeats):
                progress(f"fault {kind} on {target}, {i + 1} of {repeats}")
                if not graph.wait_nodes(tuple(NODES), 20):  # left broken: start afresh
                    stop_robot_and_runtime(graph, *procs)
                    procs, _, _ = launch(graph, settle)
                if not graph.settle(target):
                    figures.unsettled += 1
                time.sleep(3.0)
                at = time.time()
                clean = inject(graph)
                try:
                    named = graph.watch.wait(named_since(graph.watch, at, target), 15)
                    restarted = graph.watch.wait(
                        lambda t=target, a=at: logged_done(graph.watch, a, "start_node", t), 20
                    )
                    after = restarted or named or at
                    back = graph.watch.wait(all_ok_since(graph.watch, after, graph.atoms), 15)
                finally:
                    clean()
                if named is None:
                    figures.misses += 1
                    continue
                figures.detected.append(named - at)
                if restarted is not None:
                    figures.restarted.append(restarted - at)
                if back is not None:
                    figures.recovered.append(back - at)
    finally:
        stop_robot_and_runtime(graph, *procs)


def keep(tmp: Path, into: Path) -> None:
    """The learned model and what it was learned from, kept for a look afterwards."""
    import shutil

    into.mkdir(parents=True, exist_ok=True)
    for name in ("learn.bag", "learn.graph.yaml", "learn.properties.csv", "learned.ram"):
        if (tmp / name).exists():
            shutil.copy2(tmp / name, into / name)


TOPICS = (
    "/imu/data",
    "/jackal_velocity_controller/odom",
    "/imu_relayed",
    "/odom_throttled",
    "/joint_states",
    "/tf",
)


def topic_rates(graph: Graph, loads: list[int], seconds: float, window: float = 2.0) -> None:
    """The graph's rates as an independent subscriber in this process receives them (no
    racc running), per load: mean, and lowest and highest over ``window`` s windows."""
    import rospy

    os.environ["ROS_MASTER_URI"] = graph.env["ROS_MASTER_URI"]
    rospy.init_node("racc_soak_rates", anonymous=True, disable_signals=True)
    arrivals: dict[str, list[float]] = {t: [] for t in TOPICS}
    for topic in TOPICS:
        rospy.Subscriber(topic, rospy.AnyMsg, lambda _, t=topic: arrivals[t].append(time.time()))
    robot = graph.start_robot("rates_robot.log")
    try:
        graph.wait_nodes(NODES, 30)
        time.sleep(3.0)
        print(f"\ntopic rates a rospy subscriber sees, Hz (mean; lowest-highest in {window:g} s)")
        for load in loads:
            with cpu_load(graph.procs, load):
                for seen in arrivals.values():
                    seen.clear()
                start = time.time()
                time.sleep(seconds)
                end = time.time()
            row = []
            for topic, seen in arrivals.items():
                n = int((end - start) // window)
                counts = [
                    sum(start + i * window <= t < start + (i + 1) * window for t in seen) / window
                    for i in range(n)
                ]
                gaps = [b - a for a, b in itertools.pairwise(seen)]
                row.append(
                    f"{topic} {len(seen) / (end - start):.1f} ({min(counts, default=0):.1f}-"
                    f"{max(counts, default=0):.1f}, gap {max(gaps, default=0):.2f} s)"
                )
            print(f"  {load:>3} % load: " + "; ".join(row))
    finally:
        stop_robot_and_runtime(graph, robot)


def median(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}" if values else "-"


def report(soaks: list[SoakFigures], fault_figures: list[FaultFigures], argv: list[str]) -> None:
    print("\nhealthy soak (false repairs and false diagnosis episodes; bring-up excluded)")
    print(
        f"{'model':<12} {'load %':>6} {'s':>6} {'settled s':>9} {'bring-up plans':>14} "
        f"{'plans':>5} {'plans/h':>8} {'episodes':>8} {'episodes/h':>10} {'faulty %':>8}"
    )
    for s in soaks:
        settled = f"{s.settled:.1f}" if s.settled is not None else "never"
        print(
            f"{s.model:<12} {s.load:>6} {s.seconds:>6.0f} {settled:>9} {s.bring_up_plans:>14} "
            f"{s.plans:>5} {s.per_hour(s.plans):>8.0f} {s.episodes:>8} "
            f"{s.per_hour(s.episodes):>10.0f} {100 * s.faulty:>8.0f}"
        )
        for line in s.detail[:12]:
            print(f"    {line}")
    if fault_figures:
        print(
            "\nfaults (s from the injection; medians; n = diagnosed/injected; unsettled ="
            " injected while not every observation was ok)"
        )
        print(
            f"{'fault':<8} {'target':<14} {'n':>5} {'detection':>9} {'restart':>8} "
            f"{'recovery':>8} {'unsettled':>9}  detections"
        )
        for f in fault_figures:
            n = f"{len(f.detected)}/{len(f.detected) + f.misses}"
            print(
                f"{f.kind:<8} {f.target:<14} {n:>5} {median(f.detected):>9} "
                f"{median(f.restarted):>8} {median(f.recovered):>8} {f.unsettled:>9}  "
                f"{[round(x, 2) for x in f.detected]}"
            )
    print("\nreproduce:")
    print(f"  {shlex.join([os.path.relpath(sys.executable, ROOT), 'bench/soak.py', *argv])}")


QUIET = False


def progress(message: str) -> None:
    if not QUIET:
        print(f"[{time.strftime('%H:%M:%S')}] {message}", file=sys.stderr, flush=True)


def main() -> None:
    global QUIET
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--seconds", type=float, default=120.0, help="soak per load level (default 120)"
    )
    parser.add_argument(
        "--loads", default="0,50,90", help="stress-ng cpu loads in %% (default 0,50,90)"
    )
    parser.add_argument(
        "--faults",
        default="crash,freeze,rate",
        help="fault kinds to inject: crash, freeze, rate (default all; '' for none)",
    )
    parser.add_argument("--repeats", type=int, default=3, help="injections per fault (default 3)")
    parser.add_argument(
        "--settle",
        type=float,
        default=30.0,
        help="longest wait for every observation ok after launch, s (default 30)",
    )
    parser.add_argument(
        "--model", type=Path, help="the model of the graph (default tests/ros1/real_graph.ram)"
    )
    parser.add_argument(
        "--learn",
        type=int,
        default=0,
        metavar="S",
        help="also soak a model learned by racc record (S s) and racc learn (default 0: no)",
    )
    parser.add_argument(
        "--learn-loads",
        help="the load levels of the learned model's soak (default: those of --loads)",
    )
    parser.add_argument(
        "--keep-learned",
        metavar="DIR",
        type=Path,
        help="copy the recording, its graph and CSV and the learned model here (default: none)",
    )
    parser.add_argument(
        "--rates",
        action="store_true",
        help="only the topics' rates at each load, seen by a plain subscriber (default: off)",
    )
    parser.add_argument("-q", action="store_true", help="no progress lines (default: shown)")
    args = parser.parse_args()
    QUIET = args.q or not sys.stderr.isatty()
    loads = [int(x) for x in args.loads.split(",") if x]
    kinds = [k for k in args.faults.split(",") if k]
    learn_loads = [int(x) for x in (args.learn_loads or args.loads).split(",") if x]
    # `timeout` and Ctrl-C end the run through the finally blocks: nothing stays running.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(1))
    soaks: list[SoakFigures] = []
    fault_figures: list[FaultFigures] = []
    try:
        with (
            tempfile.TemporaryDirectory(prefix="racc_soak_") as tmp,
            real_graph(Path(tmp), args.model or MODEL) as graph,
        ):
            if args.rates:
                topic_rates(graph, loads, args.seconds)
                return
            name = args.model.stem if args.model else "hand-made"
            for load in loads:
                soaks.append(soak(graph, name, load, args.seconds, args.settle))
            faults(graph, kinds, args.repeats, args.settle, fault_figures)
            if args.learn:
                learned = learn_model(graph, args.learn, progress)
                if args.keep_learned:
                    keep(graph.tmp, args.keep_learned)
                graph.use_model(learned, "learned_build")
                for load in learn_loads:
                    soaks.append(soak(graph, "learned", load, args.seconds, args.settle))
    finally:
        report(soaks, fault_figures, sys.argv[1:])


if __name__ == "__main__":
    main()
