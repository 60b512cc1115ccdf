"""The repair node on ROS 2 (``racc repairer --ros 2``): Algorithm 11 on a live ROS 2
system.  The executor (:mod:`rac.runtime.repairer`) decides; this node carries out its
requests:

- start_node(n): the ``<node>`` named ``n`` in the robot's ROS 2 launch file
  (``--launch``), started as ``ros2 launch`` would start it (:mod:`rac.ros2.launch`), or
  else the command ``--restart-command`` gives (``{node}`` replaced by the node's name);
  Started nodes are detached from racc (a session of their own): they belong to the
  robot and outlive racc, under a guardian that stops them when the robot stops (its
  launch ends, or its other local nodes are gone ``robot_gone_s``), once their old
  process is proven gone (never two copies);
- stop_node(n): a process this repairer started (its session), or else every outermost
  local process whose command line says ``__node:=n``, gets SIGINT, then SIGTERM;
- kill_node(n): SIGKILL to the session racc started, or else to every local process of
  the node (a node that did not stop within the step time-out);
- shutdown(d) / power_up(d): a request on ``/board_switch`` to the board client node.
"""

from __future__ import annotations

from rac.ros2.actuator import Ros2Actuator
from rac.ros2.agent import routed_actuator
from rac.ros2.common import Session
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.nodes import RepairJob, run_repair_node
from rac.runtime.trust import BOARD_SWITCH, REPAIRER


def run_repairer(
    job: RepairJob,
    restart: str | None = None,
    name: str = "racc_repairer",
    robot_gone_s: float = DEFAULT_GONE_S,
) -> None:
    session = Session(name, key=job.key, role=REPAIRER)
    robot = job.nodes.values()  # the model's nodes: the guardian watches the others
    actuator = Ros2Actuator(session, job.launch_file, restart, robot, robot_gone_s)
    trust = session.trust
    if trust is not None:
        actuator.sealed = lambda device, value: trust.seal_kv(BOARD_SWITCH, device, value)
    try:  # the nodes racc started are left running: they belong to the robot
        routed = routed_actuator(session, job, actuator)
        run_repair_node(session, routed, job, after_tick=actuator.reap)
    finally:
        session.close()
