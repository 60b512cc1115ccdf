"""``racc ros-package``: write the ``racc`` ROS 1 package roslaunch finds the nodes in."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, add_ros_option, ros_version
from rac.load.output import resolved_path
from rac.load.ros_package import write_package


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "ros-package",
        "write the racc ROS package (ROS 1: package.xml and scripts; ROS 2: an install prefix)",
        "ROS 1: write DIR/racc, a package.xml and the executables observe, engine, repairer, "
        "board_client and demo_node, each run by this Python (a venv that sees Debian's ROS "
        "packages); put DIR on ROS_PACKAGE_PATH so that the compiled observers.launch finds "
        "them. ROS 2 (--ros 2): install the package into the prefix DIR: its ament index "
        "entry (DIR/share/ament_index/resource_index/packages/racc), DIR/share/racc/"
        "package.xml and the executables (and record) in DIR/lib/racc; put DIR on "
        "AMENT_PREFIX_PATH so that ros2 launch and ros2 run find them.",
        "  racc ros-package -o ~/ros\n  export ROS_PACKAGE_PATH=~/ros:$ROS_PACKAGE_PATH\n"
        "  racc ros-package --ros 2 -o ~/racc_ws/install\n"
        "  export AMENT_PREFIX_PATH=~/racc_ws/install:$AMENT_PREFIX_PATH",
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="DIR",
        required=True,
        help="ROS 1: the directory that gets racc/; ROS 2: the install prefix",
    )
    parser.add_argument(
        "--python", metavar="EXE", help="the Python that runs the executables (default: this one)"
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    add_ros_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    out = resolved_path(Path(args.output))
    ros = ros_version(args)
    where = write_package(out, args.python, ros)
    if not args.quiet:
        print(f"wrote {where} (executables run {args.python or sys.executable})")
        variable = "AMENT_PREFIX_PATH" if ros == 2 else "ROS_PACKAGE_PATH"
        path = os.environ.get(variable, "")
        if str(out) not in path.split(os.pathsep):
            print(f"now: export {variable}={out}{os.pathsep}${variable}")
    return 0
