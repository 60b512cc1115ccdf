"""The board client node's logic (Algorithm 13), transport-free: one connection to the
board (:class:`rac.board.client.BoardClient`, bounded retries), each MSR handed to the
transport as channel rows, and the switch requests the transport queued carried out, as
lines 12-25 of Algorithm 13 do.  A lost connection is retried every ``RETRY_S``."""

from __future__ import annotations

import asyncio
import queue
import time
from collections.abc import Callable, Sequence

from rac.board.channels import ChannelMap
from rac.board.client import BoardAddress, BoardClient, ClientSettings
from rac.errors import RacError
from rac.runtime.status import ERROR, OK, Row, channel_rows

RETRY_S = 1.0
Log = Callable[[int, str], None]


class SwitchRequests:
    """Switch requests from any transport thread (``/board_switch``: device, on|off)."""

    def __init__(self) -> None:
        self._queue: queue.Queue[tuple[str, bool]] = queue.Queue()

    def put(self, device: str, value: str) -> None:
        self._queue.put((device.strip(), value.strip().lower() in ("on", "1", "true")))

    def take(self) -> list[tuple[str, bool]]:
        out = []
        while not self._queue.empty():
            out.append(self._queue.get_nowait())
        return out


def run_board_link(
    address: BoardAddress,
    channels: ChannelMap,
    publish: Callable[[Sequence[Row]], None],
    requests: SwitchRequests,
    log: Log,
    running: Callable[[], bool],
    hz: int = 10,
    every_second: Callable[[], None] | None = None,
) -> None:
    """Until ``running()`` is false: measure, publish, switch; reconnect when lost;
    ``every_second`` (the node's status) is called about once a second meanwhile."""
    devices = dict(channels.devices)
    due = [0.0]

    def tick() -> None:
        if every_second is not None and time.monotonic() >= due[0]:
            due[0] = time.monotonic() + 1.0
            every_second()

    async def serve() -> None:
        async with BoardClient(address, ClientSettings(hz=hz)) as board:
            log(OK, f"racc board client: connected to {address}, {board.channel_count} channels")
            while running():
                tick()
                msr = await board.measure()
                publish(channel_rows([(r.on, r.current, r.voltage) for r in msr.channels], devices))
                for device, on in requests.take():
                    channel = channels.channel(device)
                    if channel is None and device.isdigit():
                        channel = int(device)
                    if channel is None:
                        log(ERROR, f"racc board client: no channel for device '{device}'")
                        continue
                    await board.switch(channel, on)
                    state = "on" if on else "off"
                    log(OK, f"t={time.time():.3f} board SWT channel {channel} ({device}) {state}")

    while running():
        tick()
        try:
            asyncio.run(serve())
        except RacError as err:
            log(ERROR, f"racc board client: {err.render()}; retrying in {RETRY_S:g} s")
            time.sleep(RETRY_S)
