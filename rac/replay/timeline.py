"""The replay timeline: observation and diagnosis records, and the episodes they form.

A timeline is what ``racc replay -o`` writes as JSON lines, one record per change::

    {"t": 12.5, "observation": "not_ok(pose)"}
    {"t": 13.0, "diagnoses": [["jaguar_node"], ["jaguar"]]}

``t`` is seconds from the start of the recording; ``"diagnoses": []`` means consistent.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

Diagnoses = tuple[tuple[str, ...], ...]


@dataclass(frozen=True, slots=True)
class ObservationRecord:
    t: float
    literal: str  # "ok(pose)" or "not_ok(pose)"


@dataclass(frozen=True, slots=True)
class DiagnosisRecord:
    t: float
    diagnoses: Diagnoses  # minimal diagnoses, fewest faults first, then by name


Record = ObservationRecord | DiagnosisRecord


@dataclass(frozen=True, slots=True)
class Timeline:
    records: tuple[Record, ...]
    duration: float  # seconds from the start to the last input

    @property
    def diagnoses(self) -> tuple[DiagnosisRecord, ...]:
        return tuple(r for r in self.records if isinstance(r, DiagnosisRecord))

    @property
    def observations(self) -> tuple[ObservationRecord, ...]:
        return tuple(r for r in self.records if isinstance(r, ObservationRecord))


@dataclass(frozen=True, slots=True)
class Episode:
    """A stretch of time during which the diagnoses were not empty."""

    start: float
    end: float | None  # None: still open when the recording ended
    diagnoses: Diagnoses  # every diagnosis published during the episode, in order, unique
    observations: tuple[str, ...]  # the negative observations seen during it

    def names(self) -> frozenset[str]:
        """Every component some diagnosis of the episode names."""
        return frozenset(c for d in self.diagnoses for c in d)


def _time(t: float) -> float:
    # Milliseconds are plenty for a timeline and keep the file free of float noise.
    return round(t, 3)


def record_json(record: Record) -> str:
    if isinstance(record, ObservationRecord):
        return json.dumps({"t": _time(record.t), "observation": record.literal})
    return json.dumps({"t": _time(record.t), "diagnoses": [list(d) for d in record.diagnoses]})


def to_jsonl(timeline: Timeline) -> str:
    return "".join(record_json(r) + "\n" for r in timeline.records)


def episodes(records: Sequence[Record]) -> tuple[Episode, ...]:
    """Split the timeline at the diagnoses: an episode opens when they become non-empty
    and closes when they are empty again.  Its observations are the negative ones held
    when it opened and those that came during it."""
    out: list[Episode] = []
    held: dict[str, None] = {}  # negative literals in Θ now
    start: float | None = None
    seen: dict[tuple[str, ...], None] = {}
    negatives: dict[str, None] = {}
    for r in records:
        if isinstance(r, ObservationRecord):
            held.pop(_opposite(r.literal), None)
            if not _positive(r.literal):
                held[r.literal] = None
                if start is not None:
                    negatives[r.literal] = None
            continue
        if r.diagnoses:
            if start is None:
                start, seen, negatives = r.t, {}, dict(held)
            seen.update(dict.fromkeys(r.diagnoses))
        elif start is not None:
            out.append(Episode(start, r.t, tuple(seen), tuple(negatives)))
            start = None
    if start is not None:
        out.append(Episode(start, None, tuple(seen), tuple(negatives)))
    return tuple(out)


NEG = "not_"


def _positive(literal: str) -> bool:
    return not literal.startswith(NEG)


def _opposite(literal: str) -> str:
    return literal.removeprefix(NEG) if literal.startswith(NEG) else NEG + literal


def diagnoses_text(diagnoses: Iterable[tuple[str, ...]]) -> str:
    """``[p2os] | [xsens_driver, imu]``"""
    return " | ".join("[" + ", ".join(d) + "]" for d in diagnoses)


def summary_lines(timeline: Timeline) -> list[str]:
    """One line per episode: when it opened, what was diagnosed, when it cleared."""
    lines = []
    for i, ep in enumerate(episodes(timeline.records), start=1):
        end = "still open at the end" if ep.end is None else f"cleared at {ep.end:.1f} s"
        lines.append(
            f"episode {i}: {ep.start:.1f} s, diagnosed {diagnoses_text(ep.diagnoses)}; {end}"
        )
        if ep.observations:
            lines.append(f"  observed: {', '.join(ep.observations)}")
    return lines
