"""Where the executables of the ``racc`` ROS 2 package start (written by
:mod:`rac.targets.ros2_package`): beside :mod:`rac.cli`, the other way in."""

from __future__ import annotations

from collections.abc import Sequence

from rac.cli import main as racc
from rac.commands.demo import demo_node_from_argv
from rac.errors import RacError
from rac.ros2 import common
from rac.ros2.demo_node import run_demo_node


def main(command: str, argv: Sequence[str]) -> int:
    """Run the node; SIGINT (Ctrl-C, ros2 launch or racc run stopping it) is a clean end:
    exit 0 and no traceback (rclpy's handler shuts the context down, then raises
    KeyboardInterrupt wherever the main thread is)."""
    args, ros_args = common.split_ros_args(argv)
    common.ROS_ARGS[:] = ros_args
    try:
        if command == "demo-node":
            return demo_node(args)
        code = racc([command, "--ros", "2", *args])
    except KeyboardInterrupt:
        return 0
    return 0 if code == INTERRUPTED else code


INTERRUPTED = 130  # racc's exit code after a KeyboardInterrupt (rac.cli)


def demo_node(argv: Sequence[str]) -> int:
    try:
        demo = demo_node_from_argv(argv, ros_version=2)
    except RacError as err:
        print(err.render())
        return 1
    run_demo_node(demo)
    return 0
