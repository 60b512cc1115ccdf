"""The board client node (Algorithm 13): board measurements in, switch requests out.

The logic is :mod:`rac.runtime.board`'s; this node publishes each MSR on
``/board_measurements`` and queues the switch requests the repair node sends on
``/board_switch`` (``diagnostic_msgs/KeyValue``: key the device, value ``on`` or ``off``),
which count only when the repairer sealed them (:mod:`rac.runtime.trust`).
"""

from __future__ import annotations

from typing import Any

from rac.board.channels import ChannelMap
from rac.board.client import BoardAddress
from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC
from rac.ros1.common import Ros1Bus
from rac.runtime.board import SwitchRequests, run_board_link
from rac.runtime.trust import BOARD_CLIENT, BOARD_SWITCH, guard_kv

SWITCH_TOPIC = "/board_switch"


def run_board_client(
    address: BoardAddress,
    channels: ChannelMap,
    *,
    hz: int = 10,
    name: str = "racc_board_client",
    key: bytes | None = None,
) -> None:
    bus = Ros1Bus(name, key, BOARD_CLIENT)
    rospy = bus.rospy
    from diagnostic_msgs.msg import KeyValue

    publish = bus.rows_publisher(BOARD_TOPIC, 10, purpose=BOARD_TOPIC)
    status = bus.rows_publisher(DIAGNOSTICS_TOPIC, 10)
    requests = SwitchRequests()
    trust = bus.trust
    gate = trust.gate(BOARD_SWITCH) if trust is not None else None
    switch = guard_kv(trust, SWITCH_TOPIC, gate, requests.put)

    def on_switch(kv: Any) -> None:
        switch(kv.key, kv.value)

    rospy.Subscriber(SWITCH_TOPIC, KeyValue, on_switch, queue_size=10)
    run_board_link(
        address,
        channels,
        publish,
        requests,
        bus.log,
        lambda: bus.ok,
        hz,
        every_second=lambda: status([trust.row()]) if trust is not None else None,
    )
