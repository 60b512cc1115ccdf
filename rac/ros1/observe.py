"""The observer host node (``racc observe``): every observer in one rospy process."""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from typing import Any

from rac.observe import ChannelState, DeviceStatus, Event
from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC, ObserverSpec
from rac.ros1.common import connection_type, from_array, require_ros, resolve_pid, to_array
from rac.runtime.host import ObserverHost, change_line
from rac.runtime.procs import ProcessProbe
from rac.runtime.status import row_channel
from rac.runtime.values import Decoders, TopicValues

OBSERVATIONS = "/observations"


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
    decoders = Decoders()
    readers: dict[str, TopicValues] = {}
    lock = threading.Lock()

    def on_message(msg: Any, topic: str) -> None:
        reader = readers.get(topic)
        if reader is None:
            with lock:
                ros_type, definition = connection_type(msg)
                fields = bank.topic_fields().get(topic, frozenset())
                reader = decoders.for_topic(topic, fields, ros_type, definition)
                readers[topic] = reader
        host.message(topic, reader.values(msg._buff))

    subs = [
        rospy.Subscriber(topic, rospy.AnyMsg, on_message, callback_args=topic, queue_size=50)
        for topic in sorted(bank.topic_fields())
    ]
    if bank.devices:

        def on_diagnostics(array: Any) -> None:
            t = host.clock()
            host.feed([DeviceStatus(t, r.name, r.hardware_id, r.level) for r in from_array(array)])

        subs.append(rospy.Subscriber(DIAGNOSTICS_TOPIC, DiagnosticArray, on_diagnostics))
    if bank.needs_board:

        def on_board(array: Any) -> None:
            t = host.clock()
            states: list[Event] = []
            for row in from_array(array):
                state = row_channel(row, t)
                if isinstance(state, ChannelState):
                    states.append(state)
            host.feed(states)

        subs.append(rospy.Subscriber(BOARD_TOPIC, DiagnosticArray, on_board))
    probe = ProcessProbe(bank.nodes, resolve_pid, bank.properties)
    rospy.loginfo(
        "racc observe: %d observers, %d topics, %d nodes", len(specs), len(subs), len(probe.nodes)
    )
    period = 1.0 / sample_hz
    last_publish = 0.0
    next_tick = time.time()
    while not rospy.is_shutdown():
        host.feed(probe.sample(host.clock()))
        host.advance()
        changes = host.take_changes()
        for v in changes:
            rospy.loginfo(change_line(v, host.owner.get(v.atom, "")))
        for error in host.take_errors()[:5]:
            rospy.logwarn("racc observe: an observer failed on %s", error)
        now = time.time()
        if changes or now - last_publish >= republish_s:
            pub.publish(to_array(host.rows()))
            last_publish = now
        next_tick += period
        delay = next_tick - time.time()
        if delay > 0:
            time.sleep(delay)
        else:
            next_tick = time.time()
