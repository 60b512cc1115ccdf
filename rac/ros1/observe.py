"""The observer host node (``racc observe``): every observer in one rospy process."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC, ObserverSpec
from rac.ros1.common import connection_type, require_ros, resolve_pid, to_array
from rac.runtime.host import HostLoop, ObserverHost, Schedule
from rac.runtime.procs import ProcessProbe
from rac.runtime.status import OBSERVATIONS, rows_from_array
from rac.runtime.values import Readers


def run_observe(
    specs: Sequence[ObserverSpec],
    *,
    sample_hz: float = 10.0,
    republish_s: float = 1.0,
    name: str = "racc_observer",
) -> None:
    rospy = require_ros()
    from diagnostic_msgs.msg import DiagnosticArray

    rospy.init_node(name)
    host = ObserverHost(specs)
    bank = host.bank
    pub = rospy.Publisher(OBSERVATIONS, DiagnosticArray, queue_size=10, latch=True)
    readers = Readers(bank.topic_fields())

    def on_message(msg: Any, topic: str) -> None:
        values, stamp = readers.read(topic, msg._buff, lambda: connection_type(msg))
        host.message(topic, values, stamp)

    subs = [
        rospy.Subscriber(topic, rospy.AnyMsg, on_message, callback_args=topic, queue_size=50)
        for topic in sorted(bank.topic_fields())
    ]
    if bank.devices:
        subs.append(
            rospy.Subscriber(
                DIAGNOSTICS_TOPIC, DiagnosticArray, lambda a: host.device_rows(rows_from_array(a))
            )
        )
    if bank.needs_board:
        subs.append(
            rospy.Subscriber(
                BOARD_TOPIC, DiagnosticArray, lambda a: host.channel_rows(rows_from_array(a))
            )
        )
    probe = ProcessProbe(bank.nodes, resolve_pid, bank.properties)
    rospy.loginfo(
        "racc observe: %d observers, %d topics, %d nodes", len(specs), len(subs), len(probe.nodes)
    )
    period = 1.0 / sample_hz
    loop = HostLoop(host, probe, republish_s, Schedule(period_s=period))
    next_tick = time.time()
    while not rospy.is_shutdown():
        step = loop.step(time.time())
        for line in step.lines:
            rospy.loginfo(line)
        for warning in step.warnings:
            rospy.logwarn("racc observe: %s", warning)
        if step.rows is not None:
            pub.publish(to_array(step.rows))
        next_tick += period
        delay = next_tick - time.time()
        if delay > 0:
            time.sleep(delay)
        else:
            next_tick = time.time()
