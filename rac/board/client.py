"""The board's client controller (Algorithms 13 and 14), made safe to use from a tool.

Algorithm 14 resends a refused command forever; here every wait has a time-out, a refused
command is resent at most ``retries`` times, and a lost connection is re-established at most
``reconnects`` times (re-reading INT and re-sending BRD/RQS) before the error reaches the user.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TypeVar

from rac.board.protocol import (
    Ack,
    AckCode,
    Broadcast,
    CodecError,
    Init,
    Measurements,
    Message,
    Request,
    Switch,
    decode,
    encode,
)
from rac.board.stream import FrameDecoder
from rac.errors import Diagnostic, RacError

T = TypeVar("T")
RECONNECT_PAUSE_S = 0.1


@dataclass(frozen=True, slots=True)
class BoardAddress:
    host: str
    port: int

    def __str__(self) -> str:
        return f"[{self.host}]:{self.port}" if ":" in self.host else f"{self.host}:{self.port}"


def parse_address(text: str) -> BoardAddress:
    """``HOST:PORT`` or ``[IPv6]:PORT``."""
    match = re.fullmatch(r"\[([^\]]+)\]:(\d+)|([^:\[\]]+):(\d+)", text.strip())
    port = int(match.group(2) or match.group(4)) if match else -1
    if match is None or not 0 < port < 65536:
        raise RacError(
            [Diagnostic("RAC090", f"'{text}' is not a board address", hint="write HOST:PORT")]
        )
    return BoardAddress(match.group(1) or match.group(3), port)


@dataclass(frozen=True, slots=True)
class ClientSettings:
    hz: int = 10  # broadcast frequency asked for with BRD
    timeout_s: float = 2.0  # any single wait for the board
    retries: int = 3  # resends of a command the board refuses (Algorithm 14, bounded)
    reconnects: int = 2  # new connections after one is lost


DEFAULT_SETTINGS = ClientSettings()


def board_error(code: str, message: str, hint: str | None = None) -> RacError:
    return RacError([Diagnostic(code, message, hint=hint)])


class BoardClient:
    """One connection to a board; use ``async with BoardClient(...) as board``."""

    def __init__(self, address: BoardAddress, settings: ClientSettings = DEFAULT_SETTINGS) -> None:
        self.address = address
        self.settings = settings
        self.init: Init | None = None
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None
        self._decoder = FrameDecoder()
        self._pending: list[Message] = []

    async def __aenter__(self) -> BoardClient:
        await self._with_reconnect(_connected)  # connects, with the bounded retries
        return self

    async def __aexit__(self, *_: object) -> None:
        await self.close()

    @property
    def channel_count(self) -> int:
        return len(self.init.channels) if self.init else 0

    async def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._writer.wait_closed(), 1.0)
        self._reader = self._writer = None

    async def measure(self) -> Measurements:
        """The next MSR the board sends (a fresh one: sent after every earlier ACK)."""
        return await self._with_reconnect(self._next_measurements)

    async def switch(self, channel: int, on: bool) -> None:
        """SWT, retried on a refusal; returns once the board ACKed 0."""

        async def go() -> None:
            await self._command(Switch(channel, on))

        await self._with_reconnect(go)

    async def wait_for_state(self, channel: int, on: bool, within_s: float) -> Measurements:
        """Read MSRs until one shows ``channel`` in state ``on``; RAC093 when none does in time."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + within_s
        while (left := deadline - loop.time()) > 0:
            try:
                msr = await asyncio.wait_for(self.measure(), left)
            except (TimeoutError, asyncio.TimeoutError):
                break  # a lost board (RAC090) is not caught: it is the better explanation
            if channel <= len(msr.channels) and msr.channels[channel - 1].on == on:
                return msr
        state = "on" if on else "off"
        raise board_error(
            "RAC093",
            f"board {self.address} did not show channel {channel} {state} within {within_s:g} s",
            hint="the relay may be stuck or the device tripping again; check the board",
        )

    # -- Algorithm 13, lines 1-11 -------------------------------------------------------
    async def _connect(self) -> None:
        await self.close()
        self._decoder = FrameDecoder()
        self._pending = []
        timeout = self.settings.timeout_s
        try:
            self._reader, self._writer = await asyncio.wait_for(
                asyncio.open_connection(self.address.host, self.address.port), timeout
            )
        except (OSError, TimeoutError, asyncio.TimeoutError) as err:
            raise board_error(
                "RAC090",
                f"cannot connect to the board at {self.address}: {str(err) or 'timed out'}",
                hint="is `racc board-sim` (or the board) running there?",
            ) from None
        first = await self._receive()
        if not isinstance(first, Init):
            raise board_error("RAC091", f"board {self.address} did not start with INT")
        self.init = first
        await self._command(Broadcast(self.settings.hz))
        await self._command(Request())

    async def _with_reconnect(self, operation: Callable[[], Awaitable[T]]) -> T:
        attempts = self.settings.reconnects + 1
        for attempt in range(attempts):
            try:
                if self._writer is None:
                    await self._connect()
                return await operation()
            except (ConnectionError, asyncio.IncompleteReadError, OSError, _Lost) as err:
                await self.close()
                if attempt + 1 == attempts:
                    raise board_error(
                        "RAC090",
                        f"lost the board at {self.address}: {str(err) or 'connection closed'}",
                    ) from None
            except RacError as err:
                codes = {d.code for d in err.diagnostics}
                if attempt + 1 == attempts or codes != {"RAC090"}:
                    raise
                await self.close()
            await asyncio.sleep(RECONNECT_PAUSE_S * (attempt + 1))
        raise AssertionError("unreachable")

    # -- Algorithm 14, bounded ------------------------------------------------------------
    async def _command(self, message: Message) -> None:
        for _ in range(self.settings.retries + 1):
            self._send(message)
            ack = await self._receive_ack()
            if ack.code is AckCode.OK:
                return
        raise board_error(
            "RAC091",
            f"board {self.address} refused {type(message).__name__} "
            f"{self.settings.retries + 1} times (ACK {int(ack.code)})",
        )

    async def _receive_ack(self) -> Ack:
        while True:
            message = await self._receive()
            if isinstance(message, Ack):
                return message
            # MSRs sent before the ACK describe the state before the command: drop them.

    async def _next_measurements(self) -> Measurements:
        while True:
            message = await self._receive()
            if isinstance(message, Measurements):
                return message

    def _send(self, message: Message) -> None:
        if self._writer is None:
            raise _Lost("not connected")
        self._writer.write(encode(message))

    async def _receive(self) -> Message:
        """The next well-formed board message; malformed frames are skipped."""
        while not self._pending:
            if self._reader is None:
                raise _Lost("not connected")
            try:
                chunk = await asyncio.wait_for(self._reader.read(4096), self.settings.timeout_s)
            except (TimeoutError, asyncio.TimeoutError):
                raise _Lost(f"no data for {self.settings.timeout_s:g} s") from None
            if not chunk:
                raise _Lost("the board closed the connection")
            for frame in self._decoder.feed(chunk):
                with contextlib.suppress(CodecError):
                    self._pending.append(decode(frame))
        return self._pending.pop(0)


async def _connected() -> None:
    return None


class _Lost(Exception):
    """The connection broke or went silent; ``_with_reconnect`` decides what happens."""
