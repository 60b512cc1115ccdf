"""The observer host node on ROS 2 (``racc observe --ros 2``): every observer in one
rclpy process.

Topics are subscribed as they appear in the graph (raw CDR, best effort, with the type the
graph names; only the fields an observer reads are deserialized, with rosbags).  NObs:
the graph (``get_node_names_and_namespaces``) and the node's process, found by its
``__node:=`` argument (:class:`rac.ros2.common.PidResolver`); PObs: cpu and memory of that
process.  The sample loop, the agent's turn and the publication rule
are :func:`rac.runtime.nodes.run_observer_node`'s, shared with ROS 1.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC, ObserverSpec
from rac.ros2.agent import start_agent
from rac.ros2.common import PidResolver, Session, graph_nodes, message_class, sensor_qos
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.host import ObserverHost
from rac.runtime.nodes import run_observer_node
from rac.runtime.procs import DEFAULT_SETTLE_S, ProcessProbe
from rac.runtime.status import rows_from_array
from rac.runtime.values import Readers

DISCOVER_S = 0.5


def run_observe(
    specs: Sequence[ObserverSpec],
    *,
    sample_hz: float = 10.0,
    republish_s: float = 1.0,
    name: str = "racc_observer",
    machine: str | None = None,
    launch: str | None = None,
    settle_s: float = DEFAULT_SETTLE_S,
    robot_gone_s: float = DEFAULT_GONE_S,
) -> None:
    session = Session(name)
    from diagnostic_msgs.msg import DiagnosticArray

    node = session.node
    host = ObserverHost(specs)
    host.source = session.name
    agent = start_agent(session, specs, machine, launch, robot_gone_s)
    bank = host.bank
    readers = Readers(bank.topic_fields(), ros_version=2)
    wanted = frozenset(bank.topic_fields())
    subs: dict[str, Any] = {}
    unknown: set[str] = set()
    next_discover = 0.0

    def subscribe(topic: str, ros_type: str) -> None:
        cls = message_class(ros_type)
        if cls is None:
            if ros_type not in unknown:
                unknown.add(ros_type)
                session.log(1, f"racc observe: {topic}: type {ros_type} is not importable")
            return

        def on_message(raw: bytes) -> None:
            values, stamp = readers.read(topic, raw, lambda: (ros_type, ""))
            host.message(topic, values, stamp)

        subs[topic] = node.create_subscription(cls, topic, on_message, sensor_qos(), raw=True)

    def discover(now: float) -> None:
        nonlocal next_discover
        if now < next_discover or len(subs) == len(wanted):
            return
        next_discover = now + DISCOVER_S
        for topic, types in node.get_topic_names_and_types():
            if topic in wanted and topic not in subs and types:
                subscribe(topic, types[0])

    for topic, feed in (
        (DIAGNOSTICS_TOPIC, host.device_rows if bank.devices else None),
        (BOARD_TOPIC, host.channel_rows if bank.needs_board else None),
    ):
        if feed is not None:
            node.create_subscription(
                DiagnosticArray, topic, lambda a, f=feed: f(rows_from_array(a)), sensor_qos()
            )
    resolver = PidResolver(lambda: graph_nodes(session))
    probe = ProcessProbe(bank.nodes, resolver, bank.properties, recheck_s=1.0, settle_s=settle_s)
    try:
        run_observer_node(
            session,
            host,
            probe,
            topics=len(wanted),
            sample_hz=sample_hz,
            republish_s=republish_s,
            agent=agent,
            machine=machine,
            each_tick=discover,
        )
    finally:
        session.close()
