"""The racc agent over rospy (rac.runtime.routing): the repairer's requests to another
machine's agent, and the agent's side in that machine's observer host."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from rac.passes.machines import node_placements
from rac.passes.observers import ObserverSpec
from rac.ros1.actuator import Ros1Actuator
from rac.ros1.common import Ros1Bus
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.nodes import RepairJob
from rac.runtime.repairer import Actuator
from rac.runtime.routing import Agent, RoutedActuator, agent_started, agent_topic, no_agent
from rac.runtime.trust import AGENT, guard_kv

CONNECT_S = 3.0  # for the agents' subscriptions to connect before the first request


def routed_actuator(bus: Ros1Bus, job: RepairJob, local: Any) -> Actuator:
    """``local`` for this machine's nodes, the agents of the others' through their topics
    (unchanged when the model places no node)."""
    if not job.placements:
        return local  # type: ignore[no-any-return]
    from diagnostic_msgs.msg import KeyValue

    rospy, trust = bus.rospy, bus.trust
    others = sorted({m for m, _ in job.placements.values() if m and m != job.machine})
    pubs = {m: rospy.Publisher(agent_topic(m), KeyValue, queue_size=10) for m in others}
    deadline = time.time() + CONNECT_S
    while any(p.get_num_connections() == 0 for p in pubs.values()) and time.time() < deadline:
        time.sleep(0.1)

    def ask(machine: str, action: str, node: str) -> None:
        pub = pubs.get(machine)
        if pub is None or pub.get_num_connections() == 0:
            raise no_agent(machine, node)
        value = trust.seal_kv(AGENT + machine, action, node) if trust is not None else node
        pub.publish(KeyValue(key=action, value=value))

    return RoutedActuator(local, job.placements, job.machine, ask)


def serve_agent(bus: Ros1Bus, agent: Agent) -> Any:
    """Subscribe the agent to its machine's requests: those the repairer sealed."""
    from diagnostic_msgs.msg import KeyValue

    topic, trust = agent_topic(agent.machine), bus.trust
    gate = trust.gate(AGENT + agent.machine) if trust is not None else None

    request = guard_kv(trust, topic, gate, agent.request)

    def receive(msg: Any) -> None:
        request(msg.key, msg.value)

    return bus.rospy.Subscriber(topic, KeyValue, receive, queue_size=20)


def start_agent(
    bus: Ros1Bus,
    specs: Sequence[ObserverSpec],
    machine: str | None,
    launch: str | None,
    robot_gone_s: float = DEFAULT_GONE_S,
) -> Agent | None:
    """The racc agent of ``machine``, restarting its nodes from ``launch`` or by their
    container; None without a machine."""
    if machine is None:
        return None
    local = Ros1Actuator(bus.rospy, launch, robot_gone_s) if launch else None
    agent = Agent(machine, node_placements(specs), local)
    serve_agent(bus, agent)
    bus.log(0, agent_started(machine, launch))
    return agent
