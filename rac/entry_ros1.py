"""Where the executables of the ``racc`` ROS 1 package start (written by
:mod:`rac.targets.ros1_package`): beside :mod:`rac.cli`, the other way in.

A demo node started by roslaunch starts its body (:mod:`rac.runtime.body`) before it
imports racc and rospy, so that the body has settled (``racc observe --settle``) soon
after the node registers: the observers judge the body's cpu and memory (getPid answers
its pid).  So this module imports only the standard library at its top.
"""

from __future__ import annotations

import subprocess
from collections.abc import Sequence

from rac.ros1.args import node_name_arg, strip_ros_args
from rac.runtime.body import start_body


def main(command: str, argv: Sequence[str]) -> int:
    """Run the node; SIGINT (Ctrl-C, roslaunch or racc run stopping it) is a clean end,
    also while racc is still being imported: exit 0 and no traceback."""
    marker = node_name_arg(argv) if command == "demo-node" else None
    # Without roslaunch's __name:= the marker needs the node's name: the body starts later.
    body = start_body([marker]) if marker else None
    args = strip_ros_args(argv)
    try:
        if command == "demo-node":
            return demo_node(args, body)
        from rac.cli import main as racc

        code = racc([command, "--ros", "1", *args])
    except KeyboardInterrupt:
        return 0
    return 0 if code == INTERRUPTED else code


INTERRUPTED = 130  # racc's exit code after a KeyboardInterrupt (rac.cli)


def demo_node(argv: Sequence[str], body: subprocess.Popen[str] | None = None) -> int:
    from rac.commands.demo import demo_node_from_argv
    from rac.errors import RacError
    from rac.ros1.demo_node import run_demo_node

    try:
        demo = demo_node_from_argv(argv, ros_version=1)
    except RacError as err:
        print(err.render())
        return 1
    run_demo_node(demo, body)
    return 0
