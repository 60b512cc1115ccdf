"""Where the executables of the ``racc`` ROS 2 package start (written by
:mod:`rac.targets.ros2_package`): beside :mod:`rac.cli`, the other way in.

A demo node starts its body (:mod:`rac.runtime.body`) before it imports racc and rclpy:
until the body exists, the node's own process is the one the observers find and measure,
and its imports take seconds on a loaded machine.  So this module imports only the
standard library at its top.
"""

from __future__ import annotations

from collections.abc import Sequence

from rac.entry import run_node
from rac.ros2.args import ROS_ARGS, split_ros_args
from rac.runtime.body import start_body


def main(command: str, argv: Sequence[str]) -> int:
    """Run the node (:func:`rac.entry.run_node`; SIGINT is a clean end)."""
    args, ros_args = split_ros_args(argv)
    ROS_ARGS[:] = ros_args
    # Without ROS arguments the body's marker needs the node's name: started later.
    body = start_body(ros_args) if command == "demo-node" and ros_args else None
    return run_node(command, args, 2, body)
