"""Where the executables of the ``racc`` ROS 2 package start (written by
:mod:`rac.targets.ros2_package`): beside :mod:`rac.cli`, the other way in.

A demo node starts its body (:mod:`rac.runtime.body`) before it imports racc and rclpy:
until the body exists, the node's own process is the one the observers find and measure,
and its imports take seconds on a loaded machine.  So this module imports only the
standard library at its top.
"""

from __future__ import annotations

import subprocess
from collections.abc import Sequence

from rac.ros2.args import split_ros_args
from rac.runtime.body import start_body

INTERRUPTED = 130  # racc's exit code after a KeyboardInterrupt (rac.cli)


def main(command: str, argv: Sequence[str]) -> int:
    """Run the node; SIGINT (Ctrl-C, ros2 launch or racc run stopping it) is a clean end:
    exit 0 and no traceback (rclpy's handler shuts the context down, then raises
    KeyboardInterrupt wherever the main thread is)."""
    args, ros_args = split_ros_args(argv)
    # Without ROS arguments the body's marker needs the node's name: started later.
    body = start_body(ros_args) if command == "demo-node" and ros_args else None
    try:
        from rac.ros2 import common

        common.ROS_ARGS[:] = ros_args
        if command == "demo-node":
            return demo_node(args, body)
        from rac.cli import main as racc

        code = racc([command, "--ros", "2", *args])
    except KeyboardInterrupt:
        return 0
    return 0 if code == INTERRUPTED else code


def demo_node(argv: Sequence[str], body: subprocess.Popen[str] | None = None) -> int:
    from rac.commands.demo import demo_node_from_argv
    from rac.errors import RacError
    from rac.ros2.demo_node import run_demo_node

    try:
        demo = demo_node_from_argv(argv, ros_version=2)
    except RacError as err:
        print(err.render())
        return 1
    run_demo_node(demo, body)
    return 0
