"""The diagnostic board's wire format (chapter 8, §8.2.3, fixed by issue 6).

A frame is ``STX | CMD | LEN | DATA``: STX is the byte 6, CMD one byte, LEN two bytes
giving the length of DATA.  Every multi-byte number on the wire is big-endian (network
order); currents and voltages are IEEE-754 float32.  The byte order lives only in the
``struct`` formats below, so it is stated in exactly one place (errata, chapter 8).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum

STX = 6
HEADER = struct.Struct(">BBH")  # STX, CMD, LEN
SPEC = struct.Struct(">ff")  # INT, per channel: max current (A), max voltage (V)
READING = struct.Struct(">Bff")  # MSR, per channel: state, current (A), voltage (V)
MAX_DATA = 0xFFFF
MAX_CHANNELS = 255  # the channel count is one byte


class Cmd(IntEnum):
    INT = 0
    BRD = 1
    MSR = 2
    RQS = 3
    SWT = 4
    ACK = 5


BOARD_COMMANDS = frozenset({Cmd.INT, Cmd.MSR, Cmd.ACK})
CLIENT_COMMANDS = frozenset({Cmd.BRD, Cmd.RQS, Cmd.SWT})


class AckCode(IntEnum):
    OK = 0
    BAD_PARAMETER = 1
    INCOMPLETE = 2


class CodecError(ValueError):
    """A frame that does not decode; ``ack`` is the code a board answers it with."""

    def __init__(self, message: str, ack: AckCode = AckCode.BAD_PARAMETER) -> None:
        super().__init__(message)
        self.ack = ack


@dataclass(frozen=True, slots=True)
class Frame:
    """One frame as framed on the wire, before its DATA is interpreted."""

    cmd: int
    data: bytes = b""


@dataclass(frozen=True, slots=True)
class ChannelSpec:
    max_current: float
    max_voltage: float


@dataclass(frozen=True, slots=True)
class Reading:
    on: bool
    current: float
    voltage: float


@dataclass(frozen=True, slots=True)
class Init:
    channels: tuple[ChannelSpec, ...]


@dataclass(frozen=True, slots=True)
class Broadcast:
    hz: int


@dataclass(frozen=True, slots=True)
class Measurements:
    channels: tuple[Reading, ...]


@dataclass(frozen=True, slots=True)
class Request:
    pass


@dataclass(frozen=True, slots=True)
class Switch:
    channel: int  # 1-based
    on: bool


@dataclass(frozen=True, slots=True)
class Ack:
    code: AckCode


Message = Init | Broadcast | Measurements | Request | Switch | Ack


def frame_bytes(frame: Frame) -> bytes:
    if len(frame.data) > MAX_DATA:
        raise CodecError(f"DATA of {len(frame.data)} bytes does not fit LEN")
    return HEADER.pack(STX, frame.cmd, len(frame.data)) + frame.data


def _byte(value: int, what: str) -> bytes:
    if not 0 <= value <= 255:
        raise CodecError(f"{what} {value} does not fit one byte")
    return bytes([value])


def to_frame(message: Message) -> Frame:
    match message:
        case Init(channels):
            body = b"".join(SPEC.pack(c.max_current, c.max_voltage) for c in channels)
            return Frame(Cmd.INT, _byte(len(channels), "channel count") + body)
        case Broadcast(hz):
            return Frame(Cmd.BRD, _byte(hz, "frequency"))
        case Measurements(channels):
            body = b"".join(READING.pack(int(r.on), r.current, r.voltage) for r in channels)
            return Frame(Cmd.MSR, _byte(len(channels), "channel count") + body)
        case Request():
            return Frame(Cmd.RQS)
        case Switch(channel, on):
            return Frame(Cmd.SWT, _byte(channel, "channel") + bytes([int(on)]))
        case Ack(code):
            return Frame(Cmd.ACK, bytes([int(code)]))
    raise TypeError(f"not a board message: {message!r}")


def encode(message: Message) -> bytes:
    """The bytes of one message on the wire."""
    return frame_bytes(to_frame(message))


def _counted(data: bytes, item: struct.Struct, name: str) -> list[tuple[float | int, ...]]:
    if not data:
        raise CodecError(f"{name} without a channel count")
    n = data[0]
    if len(data) != item.size * n + 1:
        raise CodecError(f"{name} for {n} channels needs LEN {item.size * n + 1}, got {len(data)}")
    return [item.unpack_from(data, 1 + i * item.size) for i in range(n)]


def _exact(frame: Frame, length: int, name: str) -> None:
    if len(frame.data) != length:
        raise CodecError(f"{name} needs LEN {length}, got {len(frame.data)}")


def decode(frame: Frame) -> Message:
    """Interpret a frame's DATA; raises CodecError (ACK 1) for anything malformed."""
    if frame.cmd == Cmd.INT:
        specs = _counted(frame.data, SPEC, "INT")
        return Init(tuple(ChannelSpec(float(a), float(v)) for a, v in specs))
    if frame.cmd == Cmd.BRD:
        _exact(frame, 1, "BRD")
        return Broadcast(frame.data[0])
    if frame.cmd == Cmd.MSR:
        readings = _counted(frame.data, READING, "MSR")
        for state, _, _ in readings:
            if state not in (0, 1):
                raise CodecError(f"MSR channel state {state} is not 0 or 1")
        return Measurements(tuple(Reading(s == 1, float(a), float(v)) for s, a, v in readings))
    if frame.cmd == Cmd.RQS:
        _exact(frame, 0, "RQS")
        return Request()
    if frame.cmd == Cmd.SWT:
        _exact(frame, 2, "SWT")
        channel, state = frame.data
        if state not in (0, 1):
            raise CodecError(f"SWT state {state} is not 0 or 1")
        return Switch(channel, state == 1)
    if frame.cmd == Cmd.ACK:
        _exact(frame, 1, "ACK")
        try:
            return Ack(AckCode(frame.data[0]))
        except ValueError:
            raise CodecError(f"ACK code {frame.data[0]} is not 0, 1 or 2") from None
    raise CodecError(f"unknown CMD {frame.cmd}")
