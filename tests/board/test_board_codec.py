"""The board's wire codec and streaming decoder (issue 6, §8.2.3, errata chapter 8)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from rac.board.protocol import (
    Ack,
    AckCode,
    Broadcast,
    ChannelSpec,
    CodecError,
    Frame,
    Init,
    Measurements,
    Message,
    Reading,
    Request,
    Switch,
    decode,
    encode,
)
from rac.board.stream import FrameDecoder

# Hand-assembled from the table: STX 6 | CMD | LEN (2 bytes, big-endian) | DATA.
# 15.0 = 0x41700000, 60.0 = 0x42700000, 2.5 = 0x40200000, 12.0 = 0x41400000 (float32 BE).
GOLDEN: list[tuple[Message, bytes]] = [
    # Example 8.1 as read in the errata: the ACK of a correct RQS is five bytes.
    (Ack(AckCode.OK), bytes([6, 5, 0, 1, 0])),
    (Ack(AckCode.BAD_PARAMETER), bytes([6, 5, 0, 1, 1])),
    (Ack(AckCode.INCOMPLETE), bytes([6, 5, 0, 1, 2])),
    (Request(), bytes([6, 3, 0, 0])),
    (Broadcast(10), bytes([6, 1, 0, 1, 10])),
    (Broadcast(0), bytes([6, 1, 0, 1, 0])),
    (Switch(1, True), bytes([6, 4, 0, 2, 1, 1])),
    (Switch(10, False), bytes([6, 4, 0, 2, 10, 0])),
    (
        Init((ChannelSpec(15.0, 60.0),)),
        bytes([6, 0, 0, 9, 1]) + bytes.fromhex("41700000 42700000"),
    ),
    (
        Measurements((Reading(True, 2.5, 12.0), Reading(False, 0.0, 0.0))),
        bytes([6, 2, 0, 19, 2, 1]) + bytes.fromhex("40200000 41400000") + bytes([0]) + bytes(8),
    ),
]


@pytest.mark.parametrize(("message", "wire"), GOLDEN, ids=lambda v: type(v).__name__)
def test_golden_vectors_encode_and_decode(message: Message, wire: bytes) -> None:
    assert encode(message) == wire
    frames = FrameDecoder().feed(wire)
    assert len(frames) == 1
    assert decode(frames[0]) == message


def test_int_and_msr_lengths_follow_8n_plus_1_and_9n_plus_1() -> None:
    for n in (0, 1, 10, 255):
        init = encode(Init((ChannelSpec(1.0, 2.0),) * n))
        msr = encode(Measurements((Reading(True, 1.0, 2.0),) * n))
        assert int.from_bytes(init[2:4], "big") == 8 * n + 1
        assert int.from_bytes(msr[2:4], "big") == 9 * n + 1


f32 = st.floats(width=32, allow_nan=False)
byte = st.integers(0, 255)
messages = st.one_of(
    st.builds(Init, st.lists(st.builds(ChannelSpec, f32, f32), max_size=12).map(tuple)),
    st.builds(Broadcast, byte),
    st.builds(
        Measurements, st.lists(st.builds(Reading, st.booleans(), f32, f32), max_size=12).map(tuple)
    ),
    st.just(Request()),
    st.builds(Switch, byte, st.booleans()),
    st.builds(Ack, st.sampled_from(list(AckCode))),
)


@given(messages)
def test_every_message_round_trips(message: Message) -> None:
    (frame,) = FrameDecoder().feed(encode(message))
    assert decode(frame) == message


@given(
    st.lists(messages, min_size=1, max_size=6),
    st.lists(st.binary(max_size=8).map(lambda b: b.replace(b"\x06", b"")), min_size=7, max_size=7),
    st.lists(st.integers(1, 7), max_size=40),
)
def test_stream_copes_with_split_glued_frames_and_garbage(
    batch: list[Message], garbage: list[bytes], cuts: list[int]
) -> None:
    wire = b"".join(g + encode(m) for g, m in zip(garbage, batch, strict=False))
    decoder = FrameDecoder()
    got: list[Message] = []
    position = 0
    for cut in cuts:  # arbitrary read sizes, then the rest in one read
        got += [decode(f) for f in decoder.feed(wire[position : position + cut])]
        position += cut
    got += [decode(f) for f in decoder.feed(wire[position:])]
    assert got == batch
    assert not decoder.in_frame
    assert decoder.skipped == sum(len(g) for g in garbage[: len(batch)])


def test_decoder_waits_for_long_len_and_reports_a_partial_frame() -> None:
    decoder = FrameDecoder()
    assert decoder.feed(bytes([6, 4, 0xFF, 0xFF, 1])) == []
    assert decoder.in_frame
    decoder.reset()
    assert not decoder.in_frame
    assert decoder.feed(encode(Request())) == [Frame(3, b"")]


@pytest.mark.parametrize(
    ("frame", "fragment"),
    [
        (Frame(9, b""), "unknown CMD 9"),
        (Frame(4, bytes([1, 2])), "state 2"),
        (Frame(4, bytes([1])), "SWT needs LEN 2"),
        (Frame(1, b""), "BRD needs LEN 1"),
        (Frame(3, b"x"), "RQS needs LEN 0"),
        (Frame(5, bytes([3])), "ACK code 3"),
        (Frame(0, bytes([2]) + bytes(8)), "INT for 2 channels needs LEN 17"),
        (Frame(2, b""), "MSR without a channel count"),
        (Frame(2, bytes([1, 7]) + bytes(8)), "state 7"),
    ],
)
def test_malformed_frames_are_codec_errors_answered_with_ack_1(frame: Frame, fragment: str) -> None:
    with pytest.raises(CodecError, match=fragment) as caught:
        decode(frame)
    assert caught.value.ack is AckCode.BAD_PARAMETER


def test_values_that_do_not_fit_a_byte_are_refused() -> None:
    with pytest.raises(CodecError):
        encode(Switch(256, True))
    with pytest.raises(CodecError):
        encode(Broadcast(-1))
