"""The observer host node (``racc observe``): every observer in one rospy process.

What it subscribes is this file's; the sample loop, the agent's turn and the publication
rule are :func:`rac.runtime.nodes.run_observer_node`'s, shared with ROS 2.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC, ObserverSpec
from rac.ros1.agent import start_agent
from rac.ros1.common import Ros1Bus, connection_type, node_liveness
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.host import ObserverHost
from rac.runtime.nodes import run_observer_node
from rac.runtime.procs import DEFAULT_SETTLE_S, ProcessProbe
from rac.runtime.status import rows_from_array
from rac.runtime.values import Readers


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
    bus = Ros1Bus(name)
    rospy = bus.rospy
    from diagnostic_msgs.msg import DiagnosticArray

    host = ObserverHost(specs)
    host.source = bus.name
    agent = start_agent(bus, specs, machine, launch, robot_gone_s)
    bank = host.bank
    readers = Readers(bank.topic_fields())

    def on_message(msg: Any, topic: str) -> None:
        values, stamp = readers.read(topic, msg._buff, lambda: connection_type(msg))
        host.message(topic, values, stamp)

    for topic in sorted(bank.topic_fields()):
        rospy.Subscriber(topic, rospy.AnyMsg, on_message, callback_args=topic, queue_size=50)
    if bank.devices:
        rospy.Subscriber(
            DIAGNOSTICS_TOPIC, DiagnosticArray, lambda a: host.device_rows(rows_from_array(a))
        )
    if bank.needs_board:
        rospy.Subscriber(
            BOARD_TOPIC, DiagnosticArray, lambda a: host.channel_rows(rows_from_array(a))
        )
    probe = ProcessProbe(bank.nodes, node_liveness, bank.properties, settle_s=settle_s)
    run_observer_node(
        bus,
        host,
        probe,
        topics=len(bank.topic_fields()),
        sample_hz=sample_hz,
        republish_s=republish_s,
        agent=agent,
        machine=machine,
    )
