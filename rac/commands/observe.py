"""``racc observe``: the observer host node (every observer of a model in one process)."""

from __future__ import annotations

import argparse
import functools
import math
from collections.abc import Callable
from typing import Any

from rac.commands.common import add_command, add_ros_option, ros_version
from rac.commands.options import add_robot_gone_option, add_secret_option, rate_hz
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.load.files import load_observer_file
from rac.load.secret import load_secret
from rac.observe import ObserverBank
from rac.passes.machines import machines_of, on_machine
from rac.runtime.procs import DEFAULT_SETTLE_S


def seconds_or_zero(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not 0 <= value < math.inf:
        raise argparse.ArgumentTypeError("must be 0 or more seconds")
    return value


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "observe",
        "run every observer of a model as one ROS node (ROS 1 or 2)",
        "Run the observers of OBSERVERS (the observers.yaml 'racc compile' wrote) as one rospy "
        "or rclpy node, with one subscription per topic. ROS 1: nodes are observed through "
        "the master and their XML-RPC getPid; ROS 2: through the graph and the process whose "
        "command line says __node:=NAME. cpu and memory with psutil, devices on /diagnostics, "
        "the board on /board_measurements. Observations go to /observations as "
        "diagnostic_msgs DiagnosticArray, one status per literal (docs/runtime.md). Needs "
        "ROS 1 (rospy) or ROS 2 (rclpy).",
        "  racc observe build/tedusar/observers.yaml\n"
        "  racc observe build/tedusar/observers.yaml --rate 20\n"
        "  racc observe build/tedusar/observers.yaml --ros 2",
    )
    parser.add_argument("observers", metavar="OBSERVERS", help="observers.yaml")
    parser.add_argument(
        "--rate",
        type=rate_hz,
        default=10.0,
        help="node and property samples per second (default: 10)",
    )
    parser.add_argument(
        "--settle",
        type=seconds_or_zero,
        default=DEFAULT_SETTLE_S,
        metavar="S",
        help="seconds a node's process runs before its cpu and memory are judged: a node's "
        "start-up (imports, loading its configuration) is no overload "
        f"(default: {DEFAULT_SETTLE_S:g}; 0 judges from the first sample)",
    )
    parser.add_argument(
        "--machine",
        metavar="NAME",
        help="the robot's machine this host runs on: only its observers (observers.yaml's "
        "'machine'), as node racc_observer_NAME, and the racc agent that restarts its nodes "
        "(default: every observer, one host for the whole robot)",
    )
    parser.add_argument(
        "--launch",
        metavar="FILE",
        help="with --machine: the launch file the agent restarts this machine's nodes from "
        "(default: none; nodes in containers are restarted by their container)",
    )
    parser.add_argument(
        "--statistics",
        choices=("auto", "off"),
        default="off",
        help="ROS 1: take a topic watched only for its rate and liveness from the topic "
        "statistics its subscribers in the model publish on /statistics, rather than "
        "receive it (auto: when the robot's /enable_statistics is true at the start; off: "
        "receive every topic; docs/runtime.md says what it saves and what it costs: a "
        "subscriber counts what arrived, so messages lost on the way read as a slower "
        "publisher; default: off)",
    )
    add_secret_option(parser)
    add_robot_gone_option(parser)
    add_ros_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    loaded = load_observer_file(args.observers)
    specs = loaded.specs
    ObserverBank(specs)  # RAC050/RAC051 before any ROS work
    machine = args.machine or None
    if machine is not None and machine not in machines_of(specs):
        known = ", ".join(machines_of(specs)) or "none"
        raise RacError(
            [
                Diagnostic(
                    "RAC140",
                    f"{args.observers}: no observer runs on machine '{machine}' (machines: "
                    f"{known})",
                    hint=did_you_mean(machine, machines_of(specs))
                    or "give a machine the model declares ('machine NAME'), or leave --machine out",
                )
            ]
        )
    specs = on_machine(specs, machine)
    name = f"racc_observer_{machine}" if machine else "racc_observer"
    key = load_secret(args.secret or None)
    sources = dict(loaded.sources) if loaded.sources is not None else None
    start: Callable[..., None]
    if ros_version(args) == 2:
        from rac.ros2.observe import run_observe

        if args.statistics != "off":
            print("racc observe: --statistics is ROS 1's (roscpp's /statistics): ignored")
        start = run_observe
    else:
        from rac.ros1.observe import run_observe as run_ros1

        start = functools.partial(run_ros1, statistics=args.statistics)
    start(
        specs,
        sample_hz=args.rate,
        name=name,
        machine=machine,
        launch=args.launch or None,
        settle_s=args.settle,
        key=key,
        sources=sources,
        robot_gone_s=args.robot_gone,
    )
    return 0
