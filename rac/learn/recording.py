"""Recorded runs as numeric signals (:mod:`rac.load.bags` reads them from bags).

Each run is one :class:`Run`: per topic the receive times and a matrix of the selected
field values.  :func:`merge_runs` joins several runs into one training set (Algorithm 19).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from rac.errors import Diagnostic, RacError
from rac.learn.fields import FloatArray
from rac.observe.events import Message

IntArray = npt.NDArray[np.int64]
WRAPPING = frozenset({"yaw", "roll"})  # derived angles unwrapped into continuous signals


@dataclass(frozen=True, slots=True)
class TopicData:
    """The communication of one topic (Definition 9.3) as arrays."""

    name: str
    msg_type: str  # as the model writes it: sensor_msgs/Imu
    publishers: tuple[str, ...]  # node names from ROS 1 callerids; empty for ROS 2
    times: FloatArray  # seconds from the start of the (merged) training set
    segments: IntArray  # which run each message came from
    fields: tuple[str, ...]
    values: FloatArray  # shape (len(fields), len(times))
    # The publisher's header stamps (seconds on its clock, NaN where a message has none);
    # None when the type has no header.
    stamps: FloatArray | None = None

    @property
    def count(self) -> int:
        return int(self.times.size)

    def intervals(self) -> FloatArray:
        """Δ between successive messages of one run; the seams between runs are left out."""
        same_run = self.segments[1:] == self.segments[:-1]
        deltas: FloatArray = np.diff(self.times)[same_run]
        return deltas

    def part(self, keep: npt.NDArray[np.bool_]) -> TopicData:
        """The messages where ``keep`` holds."""
        return TopicData(
            self.name,
            self.msg_type,
            self.publishers,
            self.times[keep],
            self.segments[keep],
            self.fields,
            self.values[:, keep],
            None if self.stamps is None else self.stamps[keep],
        )


@dataclass(frozen=True, slots=True)
class Run:
    path: str
    ros_version: int
    start: float  # absolute seconds
    end: float
    topics: tuple[TopicData, ...]
    messages: int
    skipped: tuple[str, ...] = ()  # recorded topics that were not asked for


@dataclass(frozen=True, slots=True)
class Recording:
    """One training set: the topics of every run, merged."""

    runs: tuple[Run, ...]
    topics: tuple[TopicData, ...]

    @property
    def messages(self) -> int:
        return sum(r.messages for r in self.runs)

    @property
    def skipped(self) -> tuple[str, ...]:
        return tuple(sorted({t for r in self.runs for t in r.skipped}))

    def topic_by_name(self) -> dict[str, TopicData]:
        return {t.name: t for t in self.topics}


def merge_runs(runs: Sequence[Run]) -> Recording:
    """Algorithm 19: shift each run to start where the previous one ended, then concatenate.

    Times become seconds from the start of the first run.  Run i's messages are tagged
    with segment i, so frequency statistics leave the seams out.
    """
    shift = runs[0].start
    shifted: list[list[TopicData]] = []
    for i, run in enumerate(runs):
        if i:
            shift += run.start - runs[i - 1].end
        shifted.append([_shift(t, shift, i) for t in run.topics])
    by_name: dict[str, list[TopicData]] = {}
    for topics in shifted:
        for t in topics:
            by_name.setdefault(t.name, []).append(t)
    merged = tuple(_concat(parts, runs) for _, parts in sorted(by_name.items()))
    return Recording(tuple(runs), merged)


def _shift(topic: TopicData, shift: float, segment: int) -> TopicData:
    return TopicData(
        topic.name,
        topic.msg_type,
        topic.publishers,
        topic.times - shift,
        np.full(topic.times.size, segment, dtype=np.int64),
        topic.fields,
        topic.values,
        topic.stamps,
    )


def _concat(parts: list[TopicData], runs: Sequence[Run]) -> TopicData:
    first = parts[0]
    for other in parts[1:]:
        if (other.msg_type, other.fields) != (first.msg_type, first.fields):
            paths = ", ".join(r.path for r in runs)
            msg = f"topic {first.name} has different types or fields across the runs ({paths})"
            raise RacError([Diagnostic("RAC080", msg)])
    if len(parts) == 1:
        return first
    values = np.concatenate([p.values for p in parts], axis=1)
    for i, f in enumerate(first.fields):
        if f in WRAPPING:
            values[i] = np.unwrap(values[i])
    stamps = None
    if all(p.stamps is not None for p in parts):
        stamps = np.concatenate([p.stamps for p in parts if p.stamps is not None])
    return TopicData(
        first.name,
        first.msg_type,
        tuple(sorted({n for p in parts for n in p.publishers})),
        np.concatenate([p.times for p in parts]),
        np.concatenate([p.segments for p in parts]),
        first.fields,
        values,
        stamps,
    )


def message_stream(
    topics: Sequence[TopicData], origin: float, segment: int | None = None
) -> list[Message]:
    """The messages of ``topics`` in time order as observer inputs, times from ``origin``;
    only those of run ``segment`` when given."""
    parts = []
    for t in topics:
        keep = np.ones(t.count, dtype=bool) if segment is None else t.segments == segment
        if keep.any():
            parts.append((t, np.flatnonzero(keep)))
    if not parts:
        return []
    times = np.concatenate([t.times[rows] for t, rows in parts]) - origin
    which = np.concatenate(
        [np.full(rows.size, i, dtype=np.int64) for i, (_, rows) in enumerate(parts)]
    )
    index = np.concatenate([rows for _, rows in parts])
    order = np.argsort(times, kind="stable")
    columns = [t.values.T.tolist() for t, _ in parts]  # per topic: the values of each message
    stamps = [_stamp_list(t) for t, _ in parts]
    out: list[Message] = []
    append = out.append
    for t, i, r in zip(
        times[order].tolist(), which[order].tolist(), index[order].tolist(), strict=True
    ):
        topic = parts[i][0]
        values = dict(zip(topic.fields, columns[i][r], strict=True))
        column = stamps[i]
        append(Message(t, topic.name, values, None if column is None else column[r]))
    return out


def _stamp_list(topic: TopicData) -> list[float | None] | None:
    """The header stamps of a topic's messages as observer inputs (None: no stamp)."""
    if topic.stamps is None:
        return None
    return [s if math.isfinite(s) and s > 0 else None for s in topic.stamps.tolist()]
