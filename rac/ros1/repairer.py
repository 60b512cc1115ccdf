"""The repair node (``racc repairer``): Algorithm 11 executed on a live ROS 1 system.

The executor (:mod:`rac.runtime.repairer`) decides; this node carries out its requests:

- start_node(n): the entry named ``n`` in the user's launch file (``--launch``), its
  command line and environment made by roslaunch's own code (package, type, args,
  remappings, environment; the file's parameters are already on the parameter server from
  the user's own roslaunch), started detached from racc (a session of its own): the node
  belongs to the robot and outlives racc, under a guardian that stops it when the robot
  stops (its launch ends, its master is gone ``robot_gone_s``), once its old process is
  proven gone (never two copies);
- stop_node(n): a node this repairer started gets SIGINT, then SIGTERM; any other is asked
  to shut down over its XML-RPC API (as ``rosnode kill`` does), then sent SIGTERM;
- kill_node(n): SIGKILL to the node's local process (a frozen node is found by its XML-RPC
  port);
- shutdown(d) / power_up(d): a request on ``/board_switch`` to the board client node.
"""

from __future__ import annotations

import threading
import time
import xmlrpc.client

from rac.ros1.actuator import Ros1Actuator
from rac.ros1.agent import routed_actuator
from rac.ros1.common import (
    CALLER,
    Ros1Bus,
    master_uri,
    proxy,
)
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.nodes import RepairJob, run_repair_node
from rac.runtime.trust import BOARD_SWITCH, REPAIRER


class MasterWatch:
    """Is the ROS master there?  Asked once a second on a thread of its own, so that the
    repair loop reads the answer without waiting for a master that does not answer."""

    def __init__(self, period_s: float = 1.0) -> None:
        self.state: tuple[bool, str] = (True, "")
        self.period_s = period_s
        threading.Thread(target=self._watch, daemon=True).start()

    def _watch(self) -> None:
        uri = master_uri()
        while True:
            try:
                proxy(uri, 1.0).getPid(CALLER)
                self.state = (True, "")
            except (OSError, xmlrpc.client.Error):
                self.state = (False, f"the ROS master at {uri} is gone")
            time.sleep(self.period_s)

    def __call__(self) -> tuple[bool, str]:
        return self.state


def run_repairer(
    job: RepairJob, name: str = "racc_repairer", robot_gone_s: float = DEFAULT_GONE_S
) -> None:
    bus = Ros1Bus(name, job.key, REPAIRER)
    actuator = Ros1Actuator(bus.rospy, job.launch_file, robot_gone_s)
    trust = bus.trust
    if trust is not None:
        actuator.sealed = lambda device, value: trust.seal_kv(BOARD_SWITCH, device, value)
    # The nodes racc started are left running: they belong to the robot.
    routed = routed_actuator(bus, job, actuator)
    run_repair_node(bus, routed, job, after_tick=actuator.reap, middleware=MasterWatch())
