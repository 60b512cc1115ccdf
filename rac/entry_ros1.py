"""Where the executables of the ``racc`` ROS 1 package start (written by
:mod:`rac.targets.ros1_package`): beside :mod:`rac.cli`, the other way in."""

from __future__ import annotations

from collections.abc import Sequence

from rac.cli import main as racc
from rac.commands.demo import demo_node_from_argv
from rac.errors import RacError
from rac.ros1.common import strip_ros_args
from rac.ros1.demo_node import run_demo_node


def main(command: str, argv: Sequence[str]) -> int:
    args = strip_ros_args(argv)
    if command == "demo-node":
        return demo_node(args)
    return racc([command, "--ros", "1", *args])


def demo_node(argv: Sequence[str]) -> int:
    try:
        demo = demo_node_from_argv(argv, ros_version=1)
    except RacError as err:
        print(err.render())
        return 1
    run_demo_node(demo)
    return 0
