"""The board client node (Algorithm 13): board measurements in, switch requests out.

It holds one connection to the board (:class:`rac.board.client.BoardClient`, with bounded
retries), publishes each MSR on ``/board_measurements`` and carries out the switch requests
the repair node sends on ``/board_switch`` (``diagnostic_msgs/KeyValue``: key the device,
value ``on`` or ``off``), as lines 12-25 of Algorithm 13 do.
"""

from __future__ import annotations

import asyncio
import queue
import time
from typing import Any

from rac.board.channels import ChannelMap
from rac.board.client import BoardAddress, BoardClient, ClientSettings
from rac.errors import RacError
from rac.passes.observers import BOARD_TOPIC
from rac.ros1.common import require_ros, to_array
from rac.runtime.status import channel_rows

SWITCH_TOPIC = "/board_switch"
RETRY_S = 1.0


def run_board_client(
    address: BoardAddress, channels: ChannelMap, *, hz: int = 10, name: str = "racc_board_client"
) -> None:
    rospy = require_ros()
    from diagnostic_msgs.msg import DiagnosticArray, KeyValue

    rospy.init_node(name)
    pub = rospy.Publisher(BOARD_TOPIC, DiagnosticArray, queue_size=10)
    requests: queue.Queue[tuple[str, bool]] = queue.Queue()
    devices = dict(channels.devices)

    def on_switch(kv: Any) -> None:
        requests.put((kv.key.strip(), kv.value.strip().lower() in ("on", "1", "true")))

    rospy.Subscriber(SWITCH_TOPIC, KeyValue, on_switch, queue_size=10)

    async def serve() -> None:
        async with BoardClient(address, ClientSettings(hz=hz)) as board:
            rospy.loginfo(
                "racc board client: connected to %s, %d channels", address, board.channel_count
            )
            while not rospy.is_shutdown():
                msr = await board.measure()
                readings = [(r.on, r.current, r.voltage) for r in msr.channels]
                pub.publish(to_array(channel_rows(readings, devices)))
                while not requests.empty():
                    device, on = requests.get_nowait()
                    channel = channels.channel(device)
                    if channel is None and device.isdigit():
                        channel = int(device)
                    if channel is None:
                        rospy.logerr("racc board client: no channel for device '%s'", device)
                        continue
                    await board.switch(channel, on)
                    rospy.loginfo(
                        "t=%.3f board SWT channel %d (%s) %s",
                        time.time(),
                        channel,
                        device,
                        "on" if on else "off",
                    )

    while not rospy.is_shutdown():
        try:
            asyncio.run(serve())
        except RacError as err:
            rospy.logerr("racc board client: %s; retrying in %g s", err.render(), RETRY_S)
            time.sleep(RETRY_S)
