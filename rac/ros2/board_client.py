"""The board client node on ROS 2 (``racc board-client --ros 2``): Algorithm 13 through
:mod:`rac.runtime.board`; MSRs on ``/board_measurements``, switch requests from
``/board_switch`` (``diagnostic_msgs/msg/KeyValue``: key the device, value on|off), which
count only when the repairer sealed them (:mod:`rac.runtime.trust`)."""

from __future__ import annotations

from typing import Any

from rac.board.channels import ChannelMap
from rac.board.client import BoardAddress
from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC
from rac.ros2.common import Session, reliable
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
    session = Session(name, key=key, role=BOARD_CLIENT)
    from diagnostic_msgs.msg import KeyValue

    node = session.node
    publish = session.rows_publisher(BOARD_TOPIC, 10, purpose=BOARD_TOPIC)
    status = session.rows_publisher(DIAGNOSTICS_TOPIC, 10)
    requests = SwitchRequests()
    trust = session.trust
    gate = trust.gate(BOARD_SWITCH) if trust is not None else None
    switch = guard_kv(trust, SWITCH_TOPIC, gate, requests.put)

    def on_switch(kv: Any) -> None:
        switch(kv.key, kv.value)

    node.create_subscription(KeyValue, SWITCH_TOPIC, on_switch, reliable(10))
    try:
        run_board_link(
            address,
            channels,
            publish,
            requests,
            session.log,
            lambda: session.ok,
            hz,
            every_second=lambda: status([trust.row()]) if trust is not None else None,
        )
    finally:
        session.close()
