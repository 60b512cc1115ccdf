"""A streaming frame decoder: feed it whatever a socket read returned, take whole frames.

TCP delivers a byte stream, so one read may hold half a frame or three frames; bytes
before an STX are skipped (issue 6), which also resynchronises after garbage.
"""

from __future__ import annotations

from rac.board.protocol import HEADER, STX, Frame


class FrameDecoder:
    def __init__(self) -> None:
        self._buffer = bytearray()
        self.skipped = 0  # garbage bytes dropped so far, for diagnostics and tests

    def feed(self, chunk: bytes) -> list[Frame]:
        """Add received bytes; return every frame now complete, in order."""
        self._buffer += chunk
        frames: list[Frame] = []
        while True:
            self._drop_garbage()
            if len(self._buffer) < HEADER.size:
                return frames
            _, cmd, length = HEADER.unpack_from(self._buffer)
            end = HEADER.size + length
            if len(self._buffer) < end:
                return frames
            frames.append(Frame(cmd, bytes(self._buffer[HEADER.size : end])))
            del self._buffer[:end]

    @property
    def in_frame(self) -> bool:
        """True while part of a frame has arrived but not all of it."""
        return bool(self._buffer)

    def reset(self) -> None:
        """Abandon a partial frame (after the board answered it with ACK 2)."""
        self._buffer.clear()

    def _drop_garbage(self) -> None:
        start = self._buffer.find(STX)
        drop = len(self._buffer) if start < 0 else start
        if drop:
            self.skipped += drop
            del self._buffer[:drop]
