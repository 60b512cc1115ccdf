"""The board client node on ROS 2 (``racc board-client --ros 2``): Algorithm 13 through
:mod:`rac.runtime.board`; MSRs on ``/board_measurements``, switch requests from
``/board_switch`` (``diagnostic_msgs/msg/KeyValue``: key the device, value on|off)."""

from __future__ import annotations

from rac.board.channels import ChannelMap
from rac.board.client import BoardAddress
from rac.passes.observers import BOARD_TOPIC
from rac.ros2.common import Session, reliable, to_array
from rac.runtime.board import SwitchRequests, run_board_link

SWITCH_TOPIC = "/board_switch"


def run_board_client(
    address: BoardAddress, channels: ChannelMap, *, hz: int = 10, name: str = "racc_board_client"
) -> None:
    session = Session(name)
    from diagnostic_msgs.msg import DiagnosticArray, KeyValue

    node = session.node
    pub = node.create_publisher(DiagnosticArray, BOARD_TOPIC, reliable(10))
    requests = SwitchRequests()
    node.create_subscription(
        KeyValue, SWITCH_TOPIC, lambda kv: requests.put(kv.key, kv.value), reliable(10)
    )
    try:
        run_board_link(
            address,
            channels,
            lambda rows: pub.publish(to_array(session, rows)),
            requests,
            session.log,
            lambda: session.ok,
            hz,
        )
    finally:
        session.close()
