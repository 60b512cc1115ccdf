"""The observer host node on ROS 2 (``racc observe --ros 2``): every observer in one
rclpy process.

Topics are subscribed as they appear in the graph (raw CDR, best effort, with the type the
graph names; only the fields an observer reads are deserialized, with rosbags).  NObs:
the graph (``get_node_names_and_namespaces``) and the node's process, found by its
``__node:=`` argument (:class:`rac.ros2.common.PidResolver`); PObs: cpu and memory of that
process.  The observers, their schedule and the publication rule are
:class:`rac.runtime.host.HostLoop`'s.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC, ObserverSpec
from rac.ros2.common import (
    PidResolver,
    Session,
    graph_nodes,
    message_class,
    reliable,
    sensor_qos,
    to_array,
)
from rac.runtime.host import HostLoop, ObserverHost, Schedule
from rac.runtime.procs import ProcessProbe
from rac.runtime.status import OBSERVATIONS, rows_from_array
from rac.runtime.values import Readers

DISCOVER_S = 0.5


def run_observe(
    specs: Sequence[ObserverSpec],
    *,
    sample_hz: float = 10.0,
    republish_s: float = 1.0,
    name: str = "racc_observer",
) -> None:
    session = Session(name)
    from diagnostic_msgs.msg import DiagnosticArray

    node = session.node
    host = ObserverHost(specs)
    bank = host.bank
    pub = node.create_publisher(DiagnosticArray, OBSERVATIONS, reliable(10, latched=True))
    readers = Readers(bank.topic_fields(), ros_version=2)
    wanted = frozenset(bank.topic_fields())
    subs: dict[str, Any] = {}
    unknown: set[str] = set()

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

    def discover() -> None:
        for topic, types in node.get_topic_names_and_types():
            if topic in wanted and topic not in subs and types:
                subscribe(topic, types[0])

    if bank.devices:
        node.create_subscription(
            DiagnosticArray,
            DIAGNOSTICS_TOPIC,
            lambda a: host.device_rows(rows_from_array(a)),
            sensor_qos(),
        )
    if bank.needs_board:
        node.create_subscription(
            DiagnosticArray,
            BOARD_TOPIC,
            lambda a: host.channel_rows(rows_from_array(a)),
            sensor_qos(),
        )
    resolver = PidResolver(lambda: graph_nodes(session))
    probe = ProcessProbe(bank.nodes, resolver, bank.properties, recheck_s=1.0)
    session.log(
        0,
        f"racc observe: {len(specs)} observers, {len(wanted)} topics, {len(probe.nodes)} nodes",
    )
    period = 1.0 / sample_hz
    loop = HostLoop(host, probe, republish_s, Schedule(period_s=period))
    next_tick = next_discover = time.time()
    try:
        while session.ok:
            now = time.time()
            if now >= next_discover and len(subs) < len(wanted):
                discover()
                next_discover = now + DISCOVER_S
            step = loop.step(now)
            for line in step.lines:
                session.log(0, line)
            for warning in step.warnings:
                session.log(1, f"racc observe: {warning}")
            if step.rows is not None:
                pub.publish(to_array(session, step.rows))
            next_tick += period
            delay = next_tick - time.time()
            if delay > 0:
                time.sleep(delay)
            else:
                next_tick = time.time()
    finally:
        session.close()
