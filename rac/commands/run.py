"""``racc run``: the runtime a compiled launch file describes, without roslaunch or
ros2 launch."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from rac.commands.common import CommandParser, add_command, add_ros_option, ros_version
from rac.errors import Diagnostic, RacError
from rac.load.kinds import COMPILED, ROBOT_LAUNCH, check_kind
from rac.runtime.launcher import (
    Supervisor,
    describe_arguments,
    launch_arguments,
    parse_assignments,
    stop_on_signals,
)

LAUNCH_FILES = {1: "observers.launch", 2: "observers.launch.xml"}


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "run",
        "run the runtime a compiled launch file describes (ROS 1 or 2, no roslaunch needed)",
        "Start the nodes that DIR/observers.launch (ROS 1) or DIR/observers.launch.xml (ROS 2) "
        "names, as roslaunch or ros2 launch would: the observer host, the diagnosis engine, "
        "the repair engine and the board client, each a process of its own whose output is "
        "shown prefixed with its name. racc's own nodes run in this Python (no racc ROS "
        "package needed); other packages' nodes are found as roslaunch (ROS_PACKAGE_PATH) or "
        "ros2 run (AMENT_PREFIX_PATH) finds them. NAME:=VALUE sets an argument of the launch "
        "file (board:=HOST:PORT, diagnosis_rate:=2, ...: --args lists them). Ctrl-C or "
        "SIGTERM stops every node (SIGINT, then SIGTERM and SIGKILL after 10 s each); when a "
        "node ends by itself, the others are stopped and racc run exits 1. ROS 1 needs a "
        "running master (roscore); ROS 2 needs rclpy (a sourced ROS 2 or the PyPI wheels). "
        "Stop racc run before the robot (docs/runtime.md, 'Stopping').",
        "  racc run build/tedusar --robot-launch /tmp/demo/robot.launch board:=127.0.0.1:7000\n"
        "  racc run build/tedusar --ros 2 --robot-launch /tmp/demo2/robot.launch.xml\n"
        "  racc run build/tedusar --args\n"
        "  racc watch            # in another terminal: what the runtime sees and does",
    )
    parser.add_argument(
        "directory", metavar="DIR", help="what racc compile wrote (or a launch file in it)"
    )
    parser.add_argument(
        "assignments",
        metavar="NAME:=VALUE",
        nargs="*",
        help="an argument of the launch file (default: the file's own default)",
    )
    parser.add_argument(
        "--robot-launch",
        metavar="FILE",
        help="the robot's own launch file, from which the repair engine restarts nodes "
        "(the same as robot_launch:=FILE; default: none, nodes cannot be restarted)",
    )
    parser.add_argument(
        "--args",
        action="store_true",
        dest="list_args",
        help="list the launch file's arguments and their defaults, start nothing",
    )
    parser.add_argument(
        "--duration",
        metavar="S",
        type=float,
        help="stop after S seconds (default: until Ctrl-C or SIGTERM)",
    )
    parser.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="do not show the nodes' output (racc run's own lines still)",
    )
    add_ros_option(parser)
    assert isinstance(parser, CommandParser)
    parser.assignments = "assignments"
    parser.set_defaults(run=run)


def launch_file(directory: Path, ros: int) -> Path:
    """DIR's launch file for ``ros`` (or DIR itself when it is a file)."""
    check_kind(directory, COMPILED, "RAC130")
    if directory.is_file():
        return directory
    path = directory / LAUNCH_FILES[ros]
    if not path.is_file():
        other = directory / LAUNCH_FILES[3 - ros]
        hint = (
            f"{other.name} is there: for ROS {3 - ros}, give --ros {3 - ros}"
            if other.is_file()
            else "compile the model first: racc compile MODEL -o DIR"
        )
        raise RacError([Diagnostic("RAC130", f"{path}: no such launch file", hint=hint)])
    return path


def run(args: argparse.Namespace) -> int:
    ros = ros_version(args)
    path = launch_file(Path(args.directory), ros)
    declared = launch_arguments(path)
    if args.list_args:
        lines = describe_arguments(declared)
        print(f"{path} takes:" if lines else f"{path} takes no arguments")
        print("\n".join(lines))
        return 0
    given = list(args.assignments)
    if args.robot_launch is not None:
        check_kind(args.robot_launch, ROBOT_LAUNCH, "RAC130")
        given.append(f"robot_launch:={Path(args.robot_launch).resolve()}")
    arguments = parse_assignments(path, declared, given)
    if ros == 2:
        from rac.ros2.common import require_rclpy
        from rac.ros2.run import load_processes, restart_problems

        require_rclpy()
    else:
        from rac.ros1.run import load_processes, restart_problems
    processes = load_processes(path, arguments)
    supervisor = Supervisor(quiet=args.quiet)
    stop_on_signals(supervisor)
    shown = " ".join(f"{k}:={v}" for k, v in arguments.items())
    supervisor.say(f"{path} (ROS {ros}) {shown}".rstrip())
    robot_launch = arguments.get("robot_launch")
    for problem in restart_problems(robot_launch) if robot_launch else ():
        supervisor.say(f"warning: {problem}")
    code = 0
    try:
        for node in processes:
            supervisor.start(node, os.environ)
        code = supervisor.wait(args.duration)
    finally:
        supervisor.stop()
    return code
