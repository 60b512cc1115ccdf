"""An asyncio simulator of the diagnostic board's server controller (Algorithm 12).

Differences from Algorithm 12, on purpose:
- several clients at once, all seeing one board;
- ``BRD f`` with f > 0 starts the MSR stream at f Hz (Figure 8.3: after BRD's ACK the board
  broadcasts), ``BRD 0`` stops it; ``RQS`` answers one MSR at once and (re)starts the stream
  when a frequency is set.  The stream is not stopped by the client's next frame (errata,
  Algorithm 12), so a client can SWT and read the result in the first MSR after the ACK;
  re-sending RQS as Algorithm 13 does is harmless;
- a frame that stays incomplete for 0.5 s is answered with ACK 2 and dropped.
Nothing a client sends ends the simulator: bad frames are ACKed with 1 or 2, and a session
that fails only closes that session.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Any

from rac.board.channels import ChannelMap
from rac.board.control import MAX_LINE, serve_control
from rac.board.protocol import (
    CLIENT_COMMANDS,
    Ack,
    AckCode,
    Broadcast,
    CodecError,
    Frame,
    Message,
    Request,
    Switch,
    decode,
    encode,
)
from rac.board.state import BoardState
from rac.board.stream import FrameDecoder

INCOMPLETE_AFTER_S = 0.5  # issue 6: idling this long inside a frame is ACK 2
MAX_CLIENTS = 32
# A connection that completes no frame this long after connecting is closed: a real client
# sends BRD or RQS at once, and 32 idle (slowloris) connections locked every client out.
FIRST_FRAME_S = 10.0
# The control port has its own connections, never counted against the board's clients, so
# a full board port cannot lock the operator out.  At most MAX_CONTROL at once: a new one
# beyond that closes the one that has been idle longest (a stuck or slowloris control
# connection), so the control port always has a slot for a new command.
MAX_CONTROL = 8
MAX_BUFFERED = 1 << 20  # a client that stops reading is dropped past this backlog
READ_SIZE = 4096
DRAIN_TIMEOUT_S = 5.0  # a client that reads nothing for this long is dropped


def _quiet(_: str) -> None:
    return None


class Session:
    """One client connection."""

    def __init__(self, sim: BoardSimulator, writer: asyncio.StreamWriter) -> None:
        self.sim = sim
        self.writer = writer
        self.hz = 0
        self.stream: asyncio.Task[None] | None = None
        peer = writer.get_extra_info("peername")
        self.name = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) else "client"

    def send(self, message: Message) -> None:
        if self.writer.transport.get_write_buffer_size() > MAX_BUFFERED:
            raise ConnectionError("client is not reading")
        self.writer.write(encode(message))

    def handle(self, frame: Frame) -> None:
        """Check, ACK, then act (Algorithm 12, lines 7-28)."""
        try:
            if frame.cmd not in CLIENT_COMMANDS:
                raise CodecError(f"CMD {frame.cmd} is not a client command")
            message = decode(frame)
            if isinstance(message, Switch) and self.sim.state.channel(message.channel) is None:
                raise CodecError(f"no channel {message.channel}")
        except CodecError as err:
            self.sim.log(f"{self.name}: ACK {int(err.ack)}: {err}")
            self.send(Ack(err.ack))
            return
        self.send(Ack(AckCode.OK))
        if isinstance(message, Broadcast):
            self.hz = message.hz
            self.restart_stream()
        elif isinstance(message, Request):
            self.send(self.sim.state.measurements())
            if self.stream is None or self.stream.done():
                self.restart_stream()
        elif isinstance(message, Switch):
            self.sim.state.switch(message.channel, message.on)
            state = "on" if message.on else "off"
            self.sim.log(f"{self.name}: switch channel {message.channel} {state}")

    def restart_stream(self) -> None:
        self.stop_stream()
        if self.hz > 0:
            self.stream = asyncio.create_task(self._broadcast(1.0 / self.hz))

    def stop_stream(self) -> None:
        if self.stream is not None:
            self.stream.cancel()
            self.stream = None

    async def _broadcast(self, period: float) -> None:
        loop = asyncio.get_running_loop()
        due = loop.time()
        try:
            while True:
                self.send(self.sim.state.measurements())
                due = max(due + period, loop.time() - period)  # late: skip, do not burst
                await asyncio.sleep(max(0.0, due - loop.time()))
        except (ConnectionError, RuntimeError):
            self.writer.close()  # the reading side then ends the session


class BoardSimulator:
    """The board: one shared state, a protocol port and a control port."""

    def __init__(
        self,
        channels: ChannelMap,
        count: int,
        *,
        seed: int = 0,
        log: Callable[[str], None] = _quiet,
    ) -> None:
        self.channels = channels
        self.state = BoardState(channels, count, seed)
        self.log = log
        self.sessions: set[Session] = set()
        # control connections -> when each last sent a line (loop time)
        self.controls: dict[asyncio.StreamWriter, float] = {}
        self._servers: list[asyncio.Server] = []
        self._tasks: set[asyncio.Task[object]] = set()

    async def start(
        self, host: str = "127.0.0.1", port: int = 0, control_port: int | None = 0
    ) -> tuple[int, int | None]:
        """Listen; the ports actually bound (0 lets the OS choose). No control when None."""
        board = await asyncio.start_server(self._serve_client, host, port)
        self._servers.append(board)
        control: int | None = None
        if control_port is not None:
            ctl = await asyncio.start_server(
                self._serve_control, host, control_port, limit=MAX_LINE
            )
            self._servers.append(ctl)
            control = ctl.sockets[0].getsockname()[1]
        return board.sockets[0].getsockname()[1], control

    async def close(self) -> None:
        for server in self._servers:
            server.close()
        for session in list(self.sessions):
            session.stop_stream()
            session.writer.close()
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        for server in self._servers:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(server.wait_closed(), 1.0)
        self._servers.clear()

    async def _serve_control(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        loop = asyncio.get_running_loop()
        if len(self.controls) >= MAX_CONTROL:
            idlest = min(self.controls, key=self.controls.__getitem__)
            self.log(f"control: {MAX_CONTROL} connections: closed the longest idle")
            self._close_control(idlest)
        self.controls[writer] = loop.time()

        def seen() -> None:
            if writer in self.controls:
                self.controls[writer] = loop.time()

        task = asyncio.current_task()
        if task is not None:
            self._tasks.add(task)
        try:
            await serve_control(self.state, self.channels, reader, writer, self.log, seen)
        finally:
            self.controls.pop(writer, None)
            if task is not None:
                self._tasks.discard(task)

    def _close_control(self, writer: asyncio.StreamWriter) -> None:
        del self.controls[writer]
        transport: Any = writer.transport
        transport.abort()  # its handler then reads EOF and ends

    async def _serve_client(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        if len(self.sessions) >= MAX_CLIENTS:
            writer.close()
            return
        session = Session(self, writer)
        self.sessions.add(session)
        task = asyncio.current_task()
        if task is not None:
            self._tasks.add(task)
        self.log(f"{session.name}: connected")
        try:
            session.send(self.state.init())
            await self._read_frames(reader, session)
        except (ConnectionError, OSError, TimeoutError, asyncio.TimeoutError) as err:
            self.log(f"{session.name}: {str(err) or 'not reading'}")
        except asyncio.CancelledError:
            pass  # closing down; a cancelled handler task only makes asyncio print noise
        except Exception as err:  # a bug must cost one session, never the board
            self.log(f"{session.name}: internal error: {err!r}")
        finally:
            session.stop_stream()
            self.sessions.discard(session)
            if task is not None:
                self._tasks.discard(task)
            writer.close()
            self.log(f"{session.name}: disconnected")

    async def _read_frames(self, reader: asyncio.StreamReader, session: Session) -> None:
        decoder = FrameDecoder()
        loop = asyncio.get_running_loop()
        first_frame_by: float | None = loop.time() + FIRST_FRAME_S  # None once one came
        while True:
            timeout = INCOMPLETE_AFTER_S if decoder.in_frame else None
            if first_frame_by is not None:
                left = max(0.0, first_frame_by - loop.time())
                timeout = left if timeout is None else min(timeout, left)
            try:
                chunk = await asyncio.wait_for(reader.read(READ_SIZE), timeout)
            except (TimeoutError, asyncio.TimeoutError):
                if first_frame_by is not None and loop.time() >= first_frame_by:
                    self.log(f"{session.name}: no complete frame in {FIRST_FRAME_S:g} s: closed")
                    return
                self.log(f"{session.name}: ACK 2: frame incomplete for {INCOMPLETE_AFTER_S} s")
                decoder.reset()
                session.send(Ack(AckCode.INCOMPLETE))
                continue
            if not chunk:
                return
            for frame in decoder.feed(chunk):
                first_frame_by = None
                session.handle(frame)
            await asyncio.wait_for(session.writer.drain(), DRAIN_TIMEOUT_S)
