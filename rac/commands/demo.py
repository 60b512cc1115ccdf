"""``racc demo``: a live demo robot made from a model (one rospy process per node)."""

from __future__ import annotations

import argparse
import itertools
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rac.board.control import send_control
from rac.commands.common import add_command, add_ros_option, count, load_checked, ros_version
from rac.errors import Diagnostic, RacError
from rac.load.files import load_model
from rac.load.output import resolved_path
from rac.load.ros_package import write_package
from rac.runtime.demo import (
    DEFAULT_PERIOD_S,
    AfterRuntime,
    DemoNode,
    FaultClock,
    due_trips,
    fault_text,
    parse_demo_fault,
    trips,
)
from rac.synth.faults import Fault
from rac.targets.demo_launch import launch_text, launch_xml_text

STOP_S = 10.0
# roslaunch gives its nodes 15 s after SIGINT, then SIGTERM: wait for all of that.
ROSLAUNCH_STOP_S = 20.0
BOARD_START_S = 20.0  # racc board-sim's start on a loaded machine


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "demo",
        "run a live demo robot made from a model (ROS 1 or 2)",
        "Start a live robot made from MODEL: every node is a rospy process publishing its "
        "topics at the model's rates with racc synth's signals and subscribing its inputs; "
        "switchable hardware sits on 'racc board-sim' channels. Writes DIR/robot.launch (the "
        "robot's launch file, for the repair engine) and DIR/ros/racc (the ROS package), then "
        "runs roslaunch on it until --duration or Ctrl-C. With ROS 2: DIR/robot.launch.xml and "
        "the package installed in the prefix DIR/ros2, and the processes the launch file names "
        "started directly (as ros2 launch would). Faults KIND@T[+D]:TARGET, T seconds "
        "after the start: crash@T:node, freq@T:/topic, slip@T:/odom, cpu@T:node, mem@T:node, "
        "trip@T:device. Needs ROS 1 (roslaunch starts a master when none answers at "
        "ROS_MASTER_URI; start roscore first for one that outlives the demo), or ROS 2 "
        "(rclpy).",
        "  racc demo models/tedusar.ram -o /tmp/demo\n"
        "  racc demo models/tedusar.ram -o /tmp/demo --fault crash@30:jaguar_node\n"
        "  racc run build/tedusar --robot-launch /tmp/demo/robot.launch board:=127.0.0.1:7000\n"
        "  racc demo models/tedusar.ram --ros 2 -o /tmp/demo2 --fault crash@30:jaguar_node",
    )
    parser.add_argument("model", metavar="MODEL", help="the robot (.ram or ram/1 .json)")
    parser.add_argument(
        "-o",
        "--output",
        metavar="DIR",
        default="demo",
        help="where the robot's launch file and the racc ROS package go (default: demo)",
    )
    parser.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="KIND@T[+D]:TARGET",
        help="inject a fault: KIND at T s for D s (default: to the end) into TARGET; T counts "
        "from the demo's start, or, written @+T, from when the runtime is first seen (its "
        "observer host starts)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the signals (default: 0)")
    parser.add_argument(
        "--duration", metavar="S", type=float, help="seconds to run (default: until Ctrl-C)"
    )
    parser.add_argument(
        "--board-port",
        metavar="PORT",
        type=int,
        default=7000,
        help="board-sim port (default: 7000)",
    )
    parser.add_argument(
        "--control-port",
        metavar="PORT",
        type=int,
        default=7001,
        help="board-sim's control port (default: 7001)",
    )
    parser.add_argument("--write-only", action="store_true", help="write the files, run nothing")
    add_ros_option(parser)
    parser.set_defaults(run=run)


def _prepend(env: dict[str, str], variable: str, path: Path) -> None:
    env[variable] = os.pathsep.join(p for p in (str(path), env.get(variable, "")) if p)


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def run(args: argparse.Namespace) -> int:
    # SIGTERM stops the demo as Ctrl-C does, its nodes with it; and SIGINT does even when a
    # shell started it in the background with SIGINT ignored.
    signal.signal(signal.SIGTERM, _interrupt)
    signal.signal(signal.SIGINT, _interrupt)
    model = load_checked(args.model)
    faults = [parse_demo_fault(f, model) for f in args.fault]
    ros = ros_version(args)
    if not args.write_only:
        # Before writing: the package's executables would run this Python, which cannot.
        _require_client_library(ros)
    out = resolved_path(Path(args.output))
    if out.exists() and not out.is_dir():
        message = f"{out}: exists and is not a directory; choose another output directory"
        raise RacError([Diagnostic("RAC004", message)])
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise RacError([Diagnostic("RAC004", f"{out}: cannot write: {err}")]) from None
    epoch = time.time()
    software = [fault_text(f) for f in faults if f.kind != "trip"]
    nodes = [n.name.value for n in model.nodes]
    model_path = str(Path(args.model).resolve())
    env = dict(os.environ)
    if ros == 2:
        prefix = write_package(out / "ros2", ros=2)
        launch = out / "robot.launch.xml"
        text = launch_xml_text(model_path, nodes, epoch, args.seed, software)
        variable = "AMENT_PREFIX_PATH"
    else:
        prefix = out / "ros"
        write_package(prefix)
        launch = out / "robot.launch"
        text = launch_text(model_path, nodes, epoch, args.seed, software)
        variable = "ROS_PACKAGE_PATH"
    launch.write_text(text, encoding="utf-8")
    print(f"wrote {launch}")
    print(f"export {variable}={prefix}{os.pathsep}${variable}")
    if args.write_only:
        return 0
    _prepend(env, variable, prefix)
    procs: list[subprocess.Popen[bytes]] = []
    try:
        if any(h.switchable for h in model.hardware):
            procs.append(_board_sim(args))
        if ros == 2:
            # The processes the launch file names, as ros2 launch starts them: a crashed
            # node stays down (its process ends) until the repair engine restarts it.
            os.environ[variable] = env[variable]
            from rac.ros2.launch import command_line, load_launch

            for entry in load_launch(launch):
                procs.append(subprocess.Popen(command_line(entry), env=env))
            watched = None
        else:
            watched = subprocess.Popen(["roslaunch", "--skip-log-check", str(launch)], env=env)
            procs.append(watched)
        _run_faults(args, faults, epoch, procs, watched, launch)
    except KeyboardInterrupt:
        pass
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.send_signal(signal.SIGINT)  # roslaunch ends its children on SIGINT
        for p in reversed(procs):
            _wait_or_kill(p)
        _stop_restarted_nodes(epoch)
    return 0


def _wait_or_kill(proc: subprocess.Popen[bytes]) -> None:
    """Wait for a process the demo started; one that outlives its time is killed, and the
    nodes a roslaunch started go with it (killing roslaunch alone would orphan them, and the
    sweep for restarted nodes would count them as a repair engine's)."""
    import psutil

    args = proc.args if isinstance(proc.args, list) else [proc.args]
    program = Path(str(args[0])).name
    wait_s = ROSLAUNCH_STOP_S if program == "roslaunch" else STOP_S
    try:
        proc.wait(wait_s)
        return
    except subprocess.TimeoutExpired:
        pass
    from rac.runtime.procs import STOP_SIGNALS, terminate

    try:
        children = [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]
    except psutil.Error:
        children = []
    proc.kill()
    proc.wait()
    for pid in children:
        terminate(pid, STOP_SIGNALS)
    print(
        f"t={time.time():.3f} demo: {program} did not stop in "
        f"{wait_s:.0f} s; stopped it and {count(len(children), 'process')} it started",
        flush=True,
    )


def demo_processes(epoch: float) -> list[int]:
    """Pids of this demo's nodes that someone else started (a repair engine restarting
    them from robot.launch): their command lines carry the demo's ``--epoch``."""
    import psutil

    mark = f"{epoch:.3f}"
    found = []
    for proc in psutil.process_iter(["cmdline"]):
        line = proc.info["cmdline"] or []
        if any(a.endswith("demo_node") for a in line[:2]) and any(
            a == "--epoch" and b == mark for a, b in itertools.pairwise(line)
        ):
            found.append(proc.pid)
    return found


def _stop_restarted_nodes(epoch: float) -> None:
    """When the demo ends, so does its robot: the nodes a repair engine restarted too
    (twice, 2 s apart, for a restart that was under way; docs/runtime.md, "Stopping")."""
    from rac.runtime.procs import STOP_SIGNALS, terminate

    for sweep in range(2):
        pids = [p for p in demo_processes(epoch) if p != os.getpid()]
        for pid in pids:
            terminate(pid, STOP_SIGNALS)
        if pids:
            stopped = count(len(pids), "restarted node")
            print(f"t={time.time():.3f} demo: stopped {stopped}", flush=True)
        if sweep == 0:
            time.sleep(2.0)


def _require_client_library(ros: int) -> None:
    """RAC057/RAC116 before anything starts: the demo nodes run on this Python, and without
    rospy (rclpy) every one of them would die with a traceback while the demo carried on."""
    if ros == 2:
        from rac.ros2.common import require_rclpy

        require_rclpy()
    else:
        from rac.ros1.common import require_ros

        require_ros()


def _board_sim(args: argparse.Namespace) -> subprocess.Popen[bytes]:
    """racc board-sim, listening: RAC132 (before any node starts) when it cannot, as when
    a port is taken (the nodes would otherwise talk to another process's board)."""
    command = [sys.executable, "-m", "rac", "board-sim", "--model", args.model]
    command += ["--port", str(args.board_port), "--control-port", str(args.control_port), "-q"]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE)
    assert proc.stdout is not None
    text = b""
    deadline = time.time() + BOARD_START_S
    while text.count(b"\n") < 2 and time.time() < deadline:
        ready, _, _ = select.select([proc.stdout], [], [], 0.2)
        chunk = os.read(proc.stdout.fileno(), 4096) if ready else b""
        text += chunk
        if (ready and not chunk) or proc.poll() is not None:
            break  # board-sim ended: its error (RAC090) is above
    listening = text.decode("utf-8", "replace").split()[:4]
    if len(listening) < 4 or proc.poll() is not None:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        raise RacError(
            [
                Diagnostic(
                    "RAC132",
                    f"the board simulator could not listen on 127.0.0.1:{args.board_port} "
                    f"and :{args.control_port}",
                    hint="another process may hold a port: choose free ones with "
                    "--board-port and --control-port",
                )
            ]
        )
    print(" ".join(listening), flush=True)  # "board 127.0.0.1:7000 control 127.0.0.1:7001"
    return proc


def _run_faults(
    args: argparse.Namespace,
    faults: Sequence[Fault],
    epoch: float,
    procs: Sequence[subprocess.Popen[bytes]],
    watched: subprocess.Popen[bytes] | None,
    launch: Path,
) -> None:
    """Trip devices on time until --duration; RAC115 when roslaunch ends early."""
    import asyncio

    pending = list(trips(faults))
    clock = FaultClock(epoch)
    # faults written KIND@+T wait for the runtime: say when it is seen
    waiting = any(isinstance(f, AfterRuntime) for f in faults)
    end = None if args.duration is None else epoch + args.duration
    while end is None or time.time() < end:
        if watched is not None and watched.poll() is not None:
            raise RacError([Diagnostic("RAC115", f"roslaunch of {launch} ended early")])
        for p in procs:
            p.poll()  # a crashed node is reaped: no zombie keeps its name
        if waiting and clock.seen(time.time()) is not None:
            waiting = False
            print(
                f"t={time.time():.3f} demo: runtime seen (its observer host started at "
                f"t={clock.runtime_seen:.3f}); faults written @+T count from there",
                flush=True,
            )
        for f in due_trips(pending, clock, time.time()):
            reply = asyncio.run(send_control("127.0.0.1", args.control_port, f"trip {f.target}"))
            print(f"t={time.time():.3f} demo fault: trip {f.target}: {reply}", flush=True)
        time.sleep(0.1)


def demo_node_from_argv(argv: Sequence[str], ros_version: int) -> DemoNode:
    """``demo_node MODEL NODE --epoch T [--seed N] [--period S] [--fault F ...]``: one node
    of the demo robot, as the executables of the racc ROS packages start it."""
    parser = argparse.ArgumentParser(prog="demo_node")
    parser.add_argument("model")
    parser.add_argument("node")
    parser.add_argument("--epoch", type=float, required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--period", type=float, default=DEFAULT_PERIOD_S)
    parser.add_argument("--fault", action="append", default=[])
    args = parser.parse_args(argv)
    model = load_model(args.model)
    return DemoNode(
        model,
        args.node,
        epoch=args.epoch,
        started=time.time(),
        seed=args.seed,
        period_s=args.period,
        faults=[parse_demo_fault(f, model) for f in args.fault],
        ros_version=ros_version,
    )
