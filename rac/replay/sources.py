"""Recorded runs as observer inputs: a bag's messages and /diagnostics, a properties CSV.

The loading layer of replay: it reads files and turns them into the time-ordered events
the observer core takes, with times in seconds from the start of the recording.

- Topic messages come from the bag through rosbags (ROS 1 ``.bag``, ROS 2 directories),
  with the fields the observers need (derived ``yaw``/``pitch``/``roll`` included).  A
  message's time is when the bag recorded it (its receive time); where its type begins with
  a ``std_msgs/Header``, it carries the header stamp as well, as on a live robot.
- ``/diagnostics`` statuses come from the bag when the model has diagnostic observers, and
  the board's channel states from its ``/board_measurements`` when it has hardware
  observers (the board client's ``channel N`` statuses, read as the live host reads them).
- The properties CSV (``time,node,cpu,mem``, the file ``racc synth`` writes and ``racc
  learn`` reads) gives CPU and memory samples, and node liveness every 0.1 s (the live
  observer host's period, or the CSV's period P if shorter) from the node's first sample on.
  ``racc record`` and ``racc synth`` sample every running node in rounds (one row per node,
  one time): a round after the node's last sample that has no row of it found no process,
  which is definite, so the node reads not running from that round on.  A node whose samples
  are not in rounds is not running once it has had no sample for 1.5·P.  At θ 5 a crash is
  reported 0.5 s after the first round that missed it, as the live host reports a vanished
  process (0.6 s); a node with no sample yet gets no verdict.
  Its ``time`` is the bag's clock in seconds, or seconds from the recording's start when
  the file's first time is smaller than the bag's start.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from rac.errors import Diagnostic, RacError
from rac.learn.fields import FieldSelector
from rac.learn.properties import Sample, property_rows
from rac.learn.recording import Run, message_stream
from rac.load.bags import MAX_SPAN_S, far_off_stamp, read_run
from rac.load.files import read_text
from rac.observe.dobs import violations_first
from rac.observe.events import (
    ChannelState,
    DeviceStatus,
    Event,
    NodeSample,
    PropertySample,
)
from rac.runtime.status import row_channel, row_from_status

DIAGNOSTICS_TOPIC = "/diagnostics"
BOARD_TOPIC = "/board_measurements"
LIVENESS_SLACK = 1.5  # a node is running when it has a sample within this many periods
# Liveness is judged this often, as the observer host samples processes live: a vanished
# process is definite evidence, and the node observer's θ checks take 0.6 s, not θ periods.
LIVENESS_STEP_S = 0.1


@dataclass(frozen=True, slots=True)
class Needs:
    """What a model's observers take from a recording."""

    topic_fields: Mapping[str, frozenset[str]]  # every model topic -> fields observers read
    nodes: frozenset[str]  # nodes with a node or property observer
    diagnostics: bool  # any diagnostic observer
    board: bool = False  # any hardware observer (fed from a recorded /board_measurements)


@dataclass(frozen=True, slots=True)
class RunInputs:
    path: str
    start: float  # the recording's start on its own clock, seconds
    duration: float  # seconds from the start to the end of the recording (its last message)
    events: tuple[Event, ...]  # in time order, times from the start
    messages: int  # topic messages among the events
    notes: tuple[str, ...]
    recorded: int = 0  # every message the recording holds, read or not (0: unknown)
    topics: int = 0  # the topics the observers read that the recording has


def properties_beside(run: str | Path) -> Path:
    """``run.bag`` -> ``run.properties.csv``; ``run/`` -> ``run.properties.csv`` beside it."""
    p = Path(run)
    name = p.name.rstrip("/")
    stem = name[: -len(".bag")] if name.endswith(".bag") else name
    return p.with_name(stem + ".properties.csv")


def load_run(path: str, needs: Needs, properties: str | None) -> RunInputs:
    """Every input a model's observers take from one recorded run."""
    run = _read_topics(path, needs)
    notes: list[str] = [*_absent_topics(path, run, needs), *_missing_fields(path, run, needs)]
    # Header stamps come with the messages (read from the same bytes in the same pass).
    events: list[Event] = list(message_stream(run.topics, run.start))
    messages = len(events)
    if needs.diagnostics:
        statuses = list(_diagnostics(path, run.start))
        if not statuses:
            notes.append(
                f"{path}: no {DIAGNOSTICS_TOPIC} messages; diagnostic observers stay silent"
            )
        events.extend(statuses)
    if needs.board:
        states = list(_board_states(path, run.start))
        if not states:
            notes.append(
                f"{path}: no {BOARD_TOPIC} messages; hardware observers stay silent, so the "
                "devices' power is not checked"
            )
        events.extend(states)
    if properties is not None:
        samples, outside, named = _properties(
            properties, run.start, run.end - run.start, needs.nodes
        )
        events.extend(samples)
        notes.extend(_unmatched_nodes(properties, named, needs.nodes))
        if outside:
            noun = "sample" if outside == 1 else "samples"
            notes.append(
                f"{properties}: {outside} {noun} outside the recording's "
                f"{run.end - run.start:.1f} s (give or take {SAMPLE_SLACK_S:g} s), dropped: "
                "is it this run's properties CSV?"
            )
    elif needs.nodes:
        notes.append(
            f"{path}: no properties CSV; node and property observers stay silent "
            "(pass --properties)"
        )
    events.sort(key=lambda e: e.t)
    # To the end of the recording: its last message of any topic, read or not, so that a
    # topic that stops near the end is judged (its silence counts up to there).
    duration = max(max((e.t for e in events), default=0.0), run.end - run.start)
    first = min((e.t for e in events), default=0.0)
    if duration - first > MAX_SPAN_S:  # the topics are bounded already: a /diagnostics stamp
        raise far_off_stamp(path, duration - first)
    recorded = _message_count(path)
    return RunInputs(
        path, run.start, duration, tuple(events), messages, tuple(notes), recorded, len(run.topics)
    )


def _message_count(path: str) -> int:
    """Every message of the recording (its index says; 0 when it cannot be told)."""

    try:
        with AnyReader([Path(path)]) as reader:
            return int(reader.message_count)
    except Exception:  # the recording was read already: a count is only for the summary
        return 0


def _absent_topics(path: str, run: Run, needs: Needs) -> Iterator[str]:
    """A note naming the model topics the recording lacks: their observers stay silent, so
    replay cannot say whether they were fine (which is not "no fault")."""
    recorded = {t.name for t in run.topics}
    absent = sorted(set(needs.topic_fields) - recorded)
    if absent:
        yield (
            f"{path}: not in the recording, so not checked: {', '.join(absent)} (their "
            "observers stay silent)"
        )


def _missing_fields(path: str, run: Run, needs: Needs) -> Iterator[str]:
    """A note per recorded topic whose messages lack fields the observers read (a model of
    another message type, a misspelt field): those observers would stay silent unsaid."""
    recorded = {t.name: t for t in run.topics}
    for topic, fields in sorted(needs.topic_fields.items()):
        data = recorded.get(topic)
        missing = sorted(fields - set(data.fields)) if data is not None else []
        if data is not None and missing:
            yield (
                f"{path}: {topic} is recorded as {data.msg_type}, which has no "
                f"{', '.join(missing)}: the observers of {'it' if len(missing) == 1 else 'them'} "
                "stay silent"
            )


def shifted(events: Iterable[Event], by: float) -> list[Event]:
    """The same events ``by`` seconds later (runs replayed back to back)."""
    import dataclasses

    return [dataclasses.replace(e, t=e.t + by) for e in events]


def _read_topics(path: str, needs: Needs) -> Run:
    selector = FieldSelector(declared=dict(needs.topic_fields))
    try:
        return read_run(path, selector, frozenset(needs.topic_fields))
    except RacError as err:
        if any("holds no messages" in d.message for d in err.diagnostics):
            topics = ", ".join(sorted(needs.topic_fields)) or "(none)"
            message = f"{path}: the recording holds none of the model's topics ({topics})"
            hint = "replay the recording with the model of the robot that recorded it"
            raise RacError([Diagnostic("RAC080", message, hint=hint)]) from None
        raise


def _diagnostics(path: str, start: float) -> Iterable[DeviceStatus]:
    """The statuses on /diagnostics (diagnostic_msgs/DiagnosticArray) of a recording."""
    out: list[DeviceStatus] = []
    for t, statuses in _status_arrays(path, DIAGNOSTICS_TOPIC, start):
        array = [
            DeviceStatus(t, str(status.name), str(status.hardware_id), _level(status.level))
            for status in statuses
        ]
        out.extend(violations_first(array))  # one check per array, at its worst
    return out


def _board_states(path: str, start: float) -> Iterable[ChannelState]:
    """The channel states on /board_measurements (the board client's DiagnosticArray, one
    ``channel N`` status per channel) of a recording, as the live observer host reads them."""
    out: list[ChannelState] = []
    for t, statuses in _status_arrays(path, BOARD_TOPIC, start):
        for status in statuses:
            # The board may report before the first model message: that is the start.
            state = row_channel(row_from_status(status), max(t, 0.0))
            if state is not None:
                out.append(state)
    return out


def _status_arrays(path: str, topic: str, start: float) -> list[tuple[float, list[Any]]]:
    """The statuses of each diagnostic_msgs/DiagnosticArray on ``topic``, with its time."""

    p = Path(path)
    store = get_typestore(Stores.ROS2_HUMBLE if p.is_dir() else Stores.ROS1_NOETIC)
    out: list[tuple[float, list[Any]]] = []
    try:
        with AnyReader([p], default_typestore=store) as reader:
            conns = [c for c in reader.connections if c.topic == topic]
            if not conns:  # an empty list would mean every connection to rosbags
                return out
            for conn, stamp, raw in reader.messages(connections=conns):
                msg = reader.deserialize(raw, conn.msgtype)
                out.append((stamp * 1e-9 - start, list(getattr(msg, "status", ()))))
    except Exception as err:  # rosbags raises many kinds on damaged files
        message = f"{path}: cannot read {topic}: {err or type(err).__name__}"
        raise RacError([Diagnostic("RAC080", message)]) from None
    return out


def _level(value: object) -> int:
    if isinstance(value, bytes | bytearray):
        return value[0] if value else 0
    return int(str(value))


# How far property samples may lie outside the recording's messages: the recorder samples
# about once a second and starts and stops beside the bag, not with it.
SAMPLE_SLACK_S = 60.0


def _unmatched_nodes(path: str, named: frozenset[str], nodes: frozenset[str]) -> Iterator[str]:
    """Notes on a properties CSV that does not fit the model: rows naming nodes the model
    lacks (read by nothing), and model nodes without a row (their observers stay silent:
    no verdict, not "no fault")."""
    stray = sorted(named - nodes)
    if stray:
        yield (
            f"{path}: samples of nodes the model lacks, not read: {', '.join(stray)} "
            "(is it this robot's CSV, or are the nodes named differently?)"
        )
    missing = sorted(nodes - named)
    if missing:
        yield (
            f"{path}: no samples of {', '.join(missing)}: their node and property observers "
            "stay silent, so nothing is known of them (not even that they ran)"
        )


def _properties(
    path: str, start: float, span: float, nodes: frozenset[str]
) -> tuple[list[Event], int, frozenset[str]]:
    """The samples of a properties CSV within the recording, how many lie outside it (a
    CSV of another run: replay would otherwise step the observers to its far times), and
    the nodes its rows name."""
    rows = parse_samples(read_text(path), path)
    if not rows:
        return [], 0, frozenset()
    relative = rows[0][0] < start
    shifted_rows = [(t if relative else t - start, n, c, m) for t, n, c, m in rows]
    samples = [r for r in shifted_rows if -SAMPLE_SLACK_S <= r[0] <= span + SAMPLE_SLACK_S]
    events: list[Event] = []
    for t, node, cpu, mem in samples:
        if cpu is not None:
            events.append(PropertySample(t, node, "cpu", cpu))
        if mem is not None:
            events.append(PropertySample(t, node, "mem", mem))
    events.extend(liveness(samples, nodes))
    return events, len(shifted_rows) - len(samples), frozenset(r[1] for r in rows)


def liveness(
    samples: Sequence[tuple[float, str, float | None, float | None]], nodes: frozenset[str]
) -> list[NodeSample]:
    """Liveness samples of each node every :data:`LIVENESS_STEP_S` from its first sample
    on (see the module's docstring)."""
    times = sorted({s[0] for s in samples})
    if len(times) < 2 or not nodes:
        return []
    period = float(np.median(np.diff(times)))
    if not period > 0:
        return []
    seen: dict[str, list[float]] = {}
    for t, node, _, _ in samples:
        seen.setdefault(node, []).append(t)
    arrays = {n: np.asarray(sorted(ts)) for n, ts in seen.items()}
    rounds = sampling_rounds(arrays)
    step = min(period, LIVENESS_STEP_S)
    out: list[NodeSample] = []
    for node in sorted(nodes):
        ts = arrays.get(node, np.empty(0))
        if not ts.size:
            continue  # never sampled: nothing says whether it ran (load_run notes it)
        # Not before its first sample: a node that starts late is not "not running" then.
        ticks = np.arange(ts[0], times[-1] + step / 2, step)
        # Samples in (tick − slack·P, tick]: counts from two sorted searches.
        hi = np.searchsorted(ts, ticks + 1e-9, side="right")
        lo = np.searchsorted(ts, ticks - LIVENESS_SLACK * period, side="right")
        alive = (hi - lo) > 0
        if _in_rounds(ts, rounds):
            # A round of the sampler that came after the node's last sample and found no
            # process: the node is not running from that round on (definite, no slack).
            last = ts[hi - 1]
            missed = np.searchsorted(rounds, ticks + 1e-9, side="right") > np.searchsorted(
                rounds, last + 1e-9, side="right"
            )
            alive &= ~missed
        out.extend(
            NodeSample(float(t), node, bool(a))
            for t, a in zip(ticks.tolist(), alive.tolist(), strict=True)
        )
    return out


ROUND_SHARE = 0.5  # a node is sampled in rounds when this share of its times are shared


def sampling_rounds(times: Mapping[str, np.ndarray]) -> np.ndarray:
    """The instants at which the sampler looked at every node (``racc record`` and ``racc
    synth`` write one row per running node with the same time), sorted: every sample time
    of the nodes sampled in rounds, those at least :data:`ROUND_SHARE` of whose times
    another node shares.  A CSV whose nodes are sampled each at its own times has none."""
    counts = Counter(t for ts in times.values() for t in set(ts.tolist()))
    together = [ts for ts in times.values() if ts.size and _shared(ts, counts) >= ROUND_SHARE]
    if not together:
        return np.empty(0)
    return np.unique(np.concatenate(together))


def _shared(ts: np.ndarray, counts: Counter[float]) -> float:
    return sum(1 for t in ts.tolist() if counts[t] >= 2) / ts.size


def _in_rounds(ts: np.ndarray, rounds: np.ndarray) -> bool:
    """Whether a node's samples come in the sampler's rounds."""
    return bool(rounds.size) and bool(np.isin(ts, rounds).mean() >= ROUND_SHARE)


def parse_samples(text: str, path: str) -> list[Sample]:
    """``time,node,cpu,mem`` rows, sorted by time; empty cpu/mem cells are missing samples."""
    return sorted(property_rows(text, path), key=lambda r: r[0])
