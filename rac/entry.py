"""What the executables of the racc ROS packages share (:mod:`rac.entry_ros1`,
:mod:`rac.entry_ros2`): one racc command, or one node of the demo robot.

racc's modules are imported only here, inside :func:`run_node`, after the caller has
started a demo node's body: until then the node's own process, busy importing, is the one
the observers would measure (see the two entries).
"""

from __future__ import annotations

import signal
import subprocess
from collections.abc import Sequence


def run_node(
    command: str, args: Sequence[str], ros: int, body: subprocess.Popen[str] | None = None
) -> int:
    """``racc COMMAND --ros ROS ARGS``, or for ``demo-node`` the demo node that ``args``
    describe, with its ``body`` if the caller started it.  SIGINT (Ctrl-C, roslaunch, ros2
    launch or racc run stopping the node) is a clean end, also while racc is still being
    imported: exit 0 and no traceback (rclpy's handler shuts the context down, then raises
    KeyboardInterrupt wherever the main thread is)."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        # Started with SIGINT ignored (a shell's background job passes that on): SIGINT is
        # how roslaunch, ros2 launch and racc stop a node, so it stops this one too.
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        if command == "demo-node":
            return _demo_node(args, ros, body)
        from rac.cli import EXIT_INTERRUPTED
        from rac.cli import main as racc

        code = racc([command, "--ros", str(ros), *args])
    except KeyboardInterrupt:
        return 0
    return 0 if code == EXIT_INTERRUPTED else code


def _demo_node(argv: Sequence[str], ros: int, body: subprocess.Popen[str] | None) -> int:
    from rac.commands.demo import demo_node_from_argv
    from rac.errors import RacError

    try:
        demo = demo_node_from_argv(argv, ros_version=ros)
    except RacError as err:
        print(err.render())
        return 1
    if ros == 1:
        from rac.ros1.demo_node import run_demo_node
    else:
        from rac.ros2.demo_node import run_demo_node
    run_demo_node(demo, body)
    return 0
