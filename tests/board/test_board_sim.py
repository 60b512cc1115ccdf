"""The board simulator over loopback: protocol, several clients, hostile input, faults."""

from __future__ import annotations

import asyncio
import contextlib
import socket
from collections.abc import Awaitable, Callable
from typing import TypeVar

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rac.board import sim as sim_module
from rac.board.channels import ChannelMap
from rac.board.control import apply_control, send_control
from rac.board.protocol import (
    Ack,
    AckCode,
    Broadcast,
    Init,
    Measurements,
    Message,
    Request,
    Switch,
    decode,
    encode,
)
from rac.board.sim import INCOMPLETE_AFTER_S, BoardSimulator
from rac.board.state import BoardState
from rac.board.stream import FrameDecoder

T = TypeVar("T")
TEDUSAR = ChannelMap(((1, "jaguar"), (2, "hokuyo"), (3, "laser_alignment")))
WAIT_S = 2.0


def run(test: Callable[[BoardSimulator, int], Awaitable[T]], limit_s: float = 10.0) -> T:
    """Run ``test(sim, port)`` against a fresh simulator; never longer than ``limit_s``."""

    async def main() -> T:
        sim = BoardSimulator(TEDUSAR, 10)
        port, _ = await sim.start(control_port=None)
        try:
            return await asyncio.wait_for(test(sim, port), limit_s)
        finally:
            await sim.close()

    return asyncio.run(main())


class Raw:
    """A bare protocol client: bytes out, decoded messages in, every wait bounded."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader, self.writer = reader, writer
        self.decoder = FrameDecoder()
        self.inbox: list[Message] = []

    @classmethod
    async def connect(cls, port: int) -> Raw:
        reader, writer = await asyncio.wait_for(asyncio.open_connection("127.0.0.1", port), WAIT_S)
        return cls(reader, writer)

    async def send(self, data: bytes | Message) -> None:
        self.writer.write(data if isinstance(data, bytes) else encode(data))
        await asyncio.wait_for(self.writer.drain(), WAIT_S)

    async def next(self, kind: type[Message] | None = None, wait_s: float = WAIT_S) -> Message:
        while True:
            while self.inbox:
                message = self.inbox.pop(0)
                if kind is None or isinstance(message, kind):
                    return message
            chunk = await asyncio.wait_for(self.reader.read(4096), wait_s)
            assert chunk, "the simulator closed the connection"
            self.inbox += [decode(f) for f in self.decoder.feed(chunk)]

    async def ack(self, wait_s: float = WAIT_S) -> AckCode:
        message = await self.next(Ack, wait_s)
        assert isinstance(message, Ack)
        return message.code

    async def msr(self) -> Measurements:
        message = await self.next(Measurements)
        assert isinstance(message, Measurements)
        return message

    def close(self) -> None:
        self.writer.close()


async def served(port: int) -> None:
    """A new client still gets INT, ACK 0 for RQS and an MSR."""
    client = await Raw.connect(port)
    assert isinstance(await client.next(), Init)
    await client.send(Request())
    assert await client.ack() is AckCode.OK
    assert len((await client.msr()).channels) == 10
    client.close()


def test_connect_gets_int_then_rqs_gets_ack_and_one_msr() -> None:
    async def test(sim: BoardSimulator, port: int) -> None:
        client = await Raw.connect(port)
        init = await client.next()
        assert isinstance(init, Init) and len(init.channels) == 10
        assert init.channels[0].max_current == 15.0 and init.channels[9].max_voltage == 20.0
        await client.send(Request())
        assert await client.ack() is AckCode.OK
        msr = await client.msr()
        assert [r.on for r in msr.channels[:4]] == [True, True, True, False]
        assert all(0 < r.current < 15.0 and r.voltage > 10 for r in msr.channels[:3])
        client.close()

    run(test)


def test_brd_sets_the_rate_and_brd_0_stops_it() -> None:
    async def test(sim: BoardSimulator, port: int) -> None:
        client = await Raw.connect(port)
        await client.next(Init)
        await client.send(Broadcast(50))
        assert await client.ack() is AckCode.OK
        loop = asyncio.get_running_loop()
        start = loop.time()
        for _ in range(11):
            await client.msr()
        elapsed = loop.time() - start  # ten periods of 20 ms after the first MSR
        assert 0.12 < elapsed < 1.0
        await client.send(Broadcast(0))
        assert await client.ack() is AckCode.OK
        client.inbox.clear()
        await asyncio.sleep(0.1)
        with_timeout = asyncio.wait_for(client.next(Measurements, wait_s=0.3), 1.0)
        try:
            await with_timeout
            raise AssertionError("MSR after BRD 0")
        except (TimeoutError, asyncio.TimeoutError):
            pass

    run(test)


def test_switch_shows_in_the_next_msr_and_in_other_clients() -> None:
    async def test(sim: BoardSimulator, port: int) -> None:
        first, second = await Raw.connect(port), await Raw.connect(port)
        for client in (first, second):
            await client.next(Init)
            await client.send(Broadcast(20))
            assert await client.ack() is AckCode.OK
        await first.send(Switch(1, False))
        assert await first.ack() is AckCode.OK
        assert not (await first.msr()).channels[0].on
        second.inbox.clear()
        await asyncio.sleep(0.1)  # MSRs sent before the switch may still be in flight
        second.inbox.clear()
        assert not (await second.msr()).channels[0].on
        await second.send(Switch(1, True))
        assert await second.ack() is AckCode.OK
        assert (await second.msr()).channels[0].on

    run(test)


def test_hostile_frames_get_ack_1_or_2_and_others_are_still_served() -> None:
    async def test(sim: BoardSimulator, port: int) -> None:
        bystander = await Raw.connect(port)
        await bystander.next(Init)
        await bystander.send(Broadcast(20))
        assert await bystander.ack() is AckCode.OK

        hostile = await Raw.connect(port)
        await hostile.next(Init)
        cases: list[tuple[bytes, AckCode]] = [
            (bytes([9, 9, 1, 2]) + encode(Request()), AckCode.OK),  # wrong STX: skipped
            (bytes([6, 42, 0, 0]), AckCode.BAD_PARAMETER),  # unknown CMD
            (bytes([6, 4, 0, 2, 11, 1]), AckCode.BAD_PARAMETER),  # no channel 11
            (bytes([6, 4, 0, 2, 0, 1]), AckCode.BAD_PARAMETER),  # channels are 1-based
            (bytes([6, 4, 0, 2, 1, 2]), AckCode.BAD_PARAMETER),  # state 2
            (bytes([6, 1, 0, 2, 5, 5]), AckCode.BAD_PARAMETER),  # BRD with LEN 2
            (encode(Ack(AckCode.OK)), AckCode.BAD_PARAMETER),  # a board-side command
            (encode(Measurements(())), AckCode.BAD_PARAMETER),
            (bytes([6, 4, 0xFF, 0xFF]) + bytes(0xFFFF), AckCode.BAD_PARAMETER),  # LEN 65535, full
        ]
        for wire, expected in cases:
            await hostile.send(wire)
            assert await hostile.ack() is expected, wire[:8]

        loop = asyncio.get_running_loop()
        for cut_short in (bytes([6, 4, 0, 10, 1, 1]), bytes([6, 4, 0xFF, 0xFF])):
            start = loop.time()
            await hostile.send(cut_short)  # LEN past the data, then silence
            assert await hostile.ack(wait_s=3.0) is AckCode.INCOMPLETE
            assert loop.time() - start >= INCOMPLETE_AFTER_S * 0.9
            await hostile.send(Switch(3, True))  # the session resynchronised
            assert await hostile.ack() is AckCode.OK

        quitter = await Raw.connect(port)
        await quitter.next(Init)
        await quitter.send(bytes([6, 4, 0, 2, 1]))  # disconnects mid-frame
        quitter.writer.transport.abort()

        bystander.inbox.clear()
        assert len((await bystander.msr()).channels) == 10
        await bystander.send(Request())
        assert await bystander.ack() is AckCode.OK
        await served(port)

    run(test)


@pytest.mark.slow
def test_a_client_that_floods_without_reading_is_dropped(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sim_module, "DRAIN_TIMEOUT_S", 0.3)

    async def test(sim: BoardSimulator, port: int) -> None:
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # fill up sooner
        sock.setblocking(False)
        await asyncio.wait_for(
            asyncio.get_running_loop().sock_connect(sock, ("127.0.0.1", port)), 2
        )
        flooder = Raw(*await asyncio.open_connection(sock=sock))
        batch = encode(Request()) * 1000  # each answered by an ACK and an MSR: ~25x the bytes
        with contextlib.suppress(ConnectionError, TimeoutError, asyncio.TimeoutError):
            for _ in range(5000):  # TCP pushes back long before this: the board stops reading
                if not sim.sessions:
                    break
                flooder.writer.write(batch)
                await asyncio.wait_for(flooder.writer.drain(), 0.5)
        await served(port)
        for _ in range(50):
            if not sim.sessions:
                break
            await asyncio.sleep(0.05)
        assert not sim.sessions  # the flooder was dropped, the board lives on
        flooder.writer.transport.abort()

    run(test, limit_s=30.0)


def test_idle_connections_that_never_complete_a_frame_do_not_lock_clients_out(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """40 connections that send nothing, or a frame's first bytes and then nothing: they held
    all 32 slots for ever and every real client was refused.  Each is closed when it has
    completed no frame FIRST_FRAME_S after connecting; a real client is served meanwhile by
    the slots left, and after the time-out by the freed ones."""
    monkeypatch.setattr(sim_module, "FIRST_FRAME_S", 1.0)

    async def test(sim: BoardSimulator, port: int) -> None:
        idle = [await Raw.connect(port) for _ in range(40)]
        for n, client in enumerate(idle):
            if n % 2:
                await client.send(encode(Request())[:3])  # a frame begun, never finished
        await asyncio.sleep(0.2)
        assert len(sim.sessions) == sim_module.MAX_CLIENTS  # the board is full
        for _ in range(40):
            if not sim.sessions:
                break
            await asyncio.sleep(0.1)
        assert not sim.sessions  # every idle connection was closed
        await served(port)
        for client in idle:
            client.close()

    run(test, limit_s=20.0)


def test_idle_connections_cannot_lock_the_control_port_out() -> None:
    """40 idle connections on the board port and 40 on the control port: the board's slots
    are full, yet a fault can still be injected, since the control port counts its own
    connections and a new one closes the longest-idle one beyond MAX_CONTROL."""

    async def main() -> None:
        sim = BoardSimulator(TEDUSAR, 10)
        port, control = await sim.start()
        assert control is not None
        idle: list[asyncio.StreamWriter] = []
        try:
            for target in (port, control):
                for _ in range(40):
                    _, writer = await asyncio.open_connection("127.0.0.1", target)
                    idle.append(writer)
            await asyncio.sleep(0.2)
            assert len(sim.sessions) == sim_module.MAX_CLIENTS  # the board port is full
            assert len(sim.controls) == sim_module.MAX_CONTROL
            reply = await send_control("127.0.0.1", control, "trip jaguar")
            assert reply == "ok trip channel 1 (jaguar)"
            assert sim.state.measurements().channels[0].on is False
            assert len(sim.controls) <= sim_module.MAX_CONTROL
        finally:
            for writer in idle:
                writer.transport.abort()
            await sim.close()

    asyncio.run(asyncio.wait_for(main(), 15.0))


def test_a_client_that_completes_a_frame_is_not_timed_out(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(sim_module, "FIRST_FRAME_S", 0.5)

    async def test(sim: BoardSimulator, port: int) -> None:
        client = await Raw.connect(port)
        await client.send(Request())
        assert await client.ack() is AckCode.OK
        await asyncio.sleep(1.0)
        assert len(sim.sessions) == 1
        await client.send(Request())
        assert await client.ack() is AckCode.OK
        client.close()

    run(test)


@settings(max_examples=30, deadline=None)
@given(st.binary(max_size=200))
def test_fuzzed_bytes_never_take_the_board_down(noise: bytes) -> None:
    async def test(sim: BoardSimulator, port: int) -> None:
        fuzzer = await Raw.connect(port)
        await fuzzer.send(noise)
        await asyncio.sleep(0.01)
        fuzzer.close()
        await served(port)

    run(test)


def test_control_lines_inject_faults() -> None:
    state = BoardState(TEDUSAR, 10)
    assert apply_control(state, TEDUSAR, "trip jaguar") == "ok trip channel 1 (jaguar)"
    assert not state.measurements().channels[0].on
    assert apply_control(state, TEDUSAR, "overcurrent 2").startswith("ok")
    assert state.measurements().channels[1].current > 15.0
    assert apply_control(state, TEDUSAR, "disconnect laser_alignment").startswith("ok")
    reading = state.measurements().channels[2]
    assert reading.on and reading.current == 0.0
    assert apply_control(state, TEDUSAR, "jam 1").startswith("ok")
    state.switch(1, True)
    assert not state.measurements().channels[0].on  # the relay does not follow SWT
    assert apply_control(state, TEDUSAR, "clear 1").startswith("ok")
    state.switch(1, True)
    assert state.measurements().channels[0].on
    assert "did you mean 'hokuyo'" in apply_control(state, TEDUSAR, "trip hokuio")
    assert apply_control(state, TEDUSAR, "trip 11").startswith("error channel 11")
    assert apply_control(state, TEDUSAR, "explode 1").startswith("error unknown command")
    assert apply_control(state, TEDUSAR, "trip").startswith("error")
    assert apply_control(state, TEDUSAR, "").startswith("error")
    assert '"device": "jaguar"' in apply_control(state, TEDUSAR, "status")


def test_control_port_trips_a_device_seen_by_a_connected_client() -> None:
    async def main() -> None:
        sim = BoardSimulator(TEDUSAR, 10)
        port, control = await sim.start()
        assert control is not None
        try:
            client = await Raw.connect(port)
            await client.next(Init)
            await client.send(Broadcast(20))
            assert await client.ack() is AckCode.OK
            reply = await send_control("127.0.0.1", control, "trip hokuyo")
            assert reply == "ok trip channel 2 (hokuyo)"
            client.inbox.clear()
            await asyncio.sleep(0.1)
            client.inbox.clear()
            assert not (await client.msr()).channels[1].on
            assert (await send_control("127.0.0.1", control, "x" * 5000)).startswith("error")
            assert (await send_control("127.0.0.1", control, "status")).startswith("ok [")
        finally:
            await sim.close()

    asyncio.run(asyncio.wait_for(main(), 10))
