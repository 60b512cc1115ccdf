"""The racc agent over rclpy (rac.runtime.routing): the repairer's requests to another
machine's agent, and the agent's side in that machine's observer host."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from rac.passes.machines import node_placements
from rac.passes.observers import ObserverSpec
from rac.ros2.actuator import Ros2Actuator
from rac.ros2.common import Session, reliable
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.nodes import RepairJob
from rac.runtime.repairer import Actuator
from rac.runtime.routing import Agent, RoutedActuator, agent_started, agent_topic, no_agent
from rac.runtime.trust import AGENT, guard_kv

CONNECT_S = 3.0  # for the agents' subscriptions to be matched before the first request


def routed_actuator(session: Session, job: RepairJob, local: Any) -> Actuator:
    """``local`` for this machine's nodes, the agents of the others' through their topics
    (unchanged when the model places no node)."""
    if not job.placements:
        return local  # type: ignore[no-any-return]
    from diagnostic_msgs.msg import KeyValue

    others = sorted({m for m, _ in job.placements.values() if m and m != job.machine})
    node = session.node
    pubs = {m: node.create_publisher(KeyValue, agent_topic(m), reliable(10)) for m in others}
    deadline = time.time() + CONNECT_S
    while any(p.get_subscription_count() == 0 for p in pubs.values()) and time.time() < deadline:
        time.sleep(0.1)

    def ask(machine: str, action: str, name: str) -> None:
        pub = pubs.get(machine)
        if pub is None or pub.get_subscription_count() == 0:
            raise no_agent(machine, name)
        trust = session.trust
        value = trust.seal_kv(AGENT + machine, action, name) if trust is not None else name
        pub.publish(KeyValue(key=action, value=value))

    return RoutedActuator(local, job.placements, job.machine, ask)


def start_agent(
    session: Session,
    specs: Sequence[ObserverSpec],
    machine: str | None,
    launch: str | None,
    robot_gone_s: float = DEFAULT_GONE_S,
) -> Agent | None:
    """The racc agent of ``machine``, restarting its nodes from ``launch`` (a ROS 2 launch
    XML file) or by their container; None without a machine."""
    if machine is None:
        return None
    from diagnostic_msgs.msg import KeyValue

    robot = node_placements(specs)  # the model's nodes: the guardian watches the others
    local = Ros2Actuator(session, launch, None, robot, robot_gone_s) if launch else None
    agent = Agent(machine, node_placements(specs), local)

    topic, trust = agent_topic(machine), session.trust
    gate = trust.gate(AGENT + machine) if trust is not None else None

    request = guard_kv(trust, topic, gate, agent.request)

    def receive(msg: Any) -> None:
        request(msg.key, msg.value)

    session.node.create_subscription(KeyValue, topic, receive, reliable(20))
    session.log(0, agent_started(machine, launch))
    return agent
