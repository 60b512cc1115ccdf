"""The board client node (Algorithm 13): board measurements in, switch requests out.

The logic is :mod:`rac.runtime.board`'s; this node publishes each MSR on
``/board_measurements`` and queues the switch requests the repair node sends on
``/board_switch`` (``diagnostic_msgs/KeyValue``: key the device, value ``on`` or ``off``).
"""

from __future__ import annotations

from typing import Any

from rac.board.channels import ChannelMap
from rac.board.client import BoardAddress
from rac.passes.observers import BOARD_TOPIC
from rac.ros1.common import log_to_ros, require_ros, to_array
from rac.runtime.board import SwitchRequests, run_board_link

SWITCH_TOPIC = "/board_switch"


def run_board_client(
    address: BoardAddress, channels: ChannelMap, *, hz: int = 10, name: str = "racc_board_client"
) -> None:
    rospy = require_ros()
    from diagnostic_msgs.msg import DiagnosticArray, KeyValue

    rospy.init_node(name)
    pub = rospy.Publisher(BOARD_TOPIC, DiagnosticArray, queue_size=10)
    requests = SwitchRequests()

    def on_switch(kv: Any) -> None:
        requests.put(kv.key, kv.value)

    rospy.Subscriber(SWITCH_TOPIC, KeyValue, on_switch, queue_size=10)
    run_board_link(
        address,
        channels,
        lambda rows: pub.publish(to_array(rows)),
        requests,
        log_to_ros(rospy),
        lambda: not rospy.is_shutdown(),
        hz,
    )
