"""A demo node's "body": a small companion process standing for the driver, so that the
observers' cpu and memory readings are those of a process the size of a real driver (a
Python ROS node alone is larger than most nodes' memory limits).

ROS 1 reports its pid through getPid; on ROS 2 it carries the node's ``__node:=`` argument
and, being the innermost process with it, is the one found.  On ROS 2 it is started before
anything else is imported (:mod:`rac.entry_ros2`): until it exists the node's own process
is the one found, and a Python process importing rclpy under load takes seconds, far over
a driver's cpu and memory limits.  cpu and mem faults act on the body; it ends with its
node (its stdin closes).  It ignores SIGINT: Ctrl-C on roslaunch (or ``timeout -s INT``)
reaches the whole process group, and the body, which ends when its node does, would
otherwise print a KeyboardInterrupt traceback per node.

Only the standard library is imported here, so that starting a body costs nothing.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Sequence

BODY = """
import os, signal, sys, threading, time
signal.signal(signal.SIGINT, signal.SIG_IGN)
state = {"cpu": 0.0, "mem": 0}
held = []
def read():
    for line in sys.stdin:
        key, _, value = line.partition(" ")
        state[key] = float(value)
    os._exit(0)
threading.Thread(target=read, daemon=True).start()
while True:
    want = int(state["mem"])
    if want and not held:
        block = bytearray(want)
        for i in range(0, want, 4096):
            block[i] = 1
        held.append(block)
    elif not want:
        held.clear()
    burn = min(max(state["cpu"], 0.0), 0.95)
    until = time.time() + burn * 0.1
    while time.time() < until:
        pass
    time.sleep(0.1 * (1 - burn))
"""


def start_body(marker: Sequence[str] = ()) -> subprocess.Popen[str]:
    """The body process; ``marker``: arguments it ignores that show on its command line."""
    return subprocess.Popen(
        [sys.executable, "-S", "-c", BODY, *marker], stdin=subprocess.PIPE, text=True, bufsize=1
    )
