"""Where the executables of the ``racc`` ROS 1 package start (written by
:mod:`rac.targets.ros1_package`): beside :mod:`rac.cli`, the other way in.

A demo node started by roslaunch starts its body (:mod:`rac.runtime.body`) before it
imports racc and rospy, so that the body has settled (``racc observe --settle``) soon
after the node registers: the observers judge the body's cpu and memory (getPid answers
its pid).  So this module imports only the standard library at its top.
"""

from __future__ import annotations

from collections.abc import Sequence

from rac.entry import run_node
from rac.ros1.args import node_name_arg, strip_ros_args
from rac.runtime.body import start_body


def main(command: str, argv: Sequence[str]) -> int:
    """Run the node (:func:`rac.entry.run_node`; SIGINT is a clean end)."""
    marker = node_name_arg(argv) if command == "demo-node" else None
    # Without roslaunch's __name:= the marker needs the node's name: the body starts later.
    body = start_body([marker]) if marker else None
    return run_node(command, strip_ros_args(argv), 1, body)
