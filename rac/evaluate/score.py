"""Scoring a replayed run against its ground truth (§10.2.2's CR, FN and FP).

- A fault is **correctly reported** (CR) when some diagnosis in effect at any time during
  its window, extended by a grace period after its end, names one of its culprits;
  otherwise it is a **false negative** (FN).
- A **false positive** (FP) is a diagnosis episode (a stretch during which the diagnoses
  are not empty) none of whose diagnoses names a culprit of a fault active during it,
  each fault's window widened by the grace period on both sides.  It is counted under the
  kind of the fault active then, or under ``none`` when no fault was.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from rac.replay.timeline import DiagnosisRecord, Episode, Timeline, episodes
from rac.synth.truth import InjectedFault as Fault

DEFAULT_GRACE_S = 5.0
NO_FAULT = "none"


@dataclass(frozen=True, slots=True)
class FaultOutcome:
    fault: Fault
    reported: bool
    first: float | None  # when a diagnosis first named a culprit
    diagnoses: tuple[tuple[str, ...], ...]  # what was diagnosed in the window


@dataclass(frozen=True, slots=True)
class FalsePositive:
    episode: Episode
    kind: str  # the kind of the fault active then, or NO_FAULT


@dataclass(frozen=True, slots=True)
class RunScore:
    outcomes: tuple[FaultOutcome, ...]
    false_positives: tuple[FalsePositive, ...]


def _in_effect(
    records: Sequence[DiagnosisRecord], start: float, end: float
) -> list[DiagnosisRecord]:
    """The diagnosis records in effect at some time in [start, end]."""
    out: list[DiagnosisRecord] = []
    before: DiagnosisRecord | None = None
    for r in records:
        if r.t <= start:
            before = r
        elif r.t <= end:
            out.append(r)
    return ([before] if before is not None else []) + out


def score_fault(fault: Fault, records: Sequence[DiagnosisRecord], grace: float) -> FaultOutcome:
    culprits = set(fault.culprits)
    seen: dict[tuple[str, ...], None] = {}
    first: float | None = None
    for r in _in_effect(records, fault.start, fault.end + grace):
        for d in r.diagnoses:
            seen[d] = None
            if first is None and culprits.intersection(d):
                first = max(r.t, fault.start)
    return FaultOutcome(fault, first is not None, first, tuple(seen))


def score_run(
    timeline: Timeline, faults: Sequence[Fault], grace: float = DEFAULT_GRACE_S
) -> RunScore:
    records = timeline.diagnoses
    outcomes = tuple(score_fault(f, records, grace) for f in faults)
    false_positives = []
    for ep in episodes(timeline.records):
        end = timeline.duration if ep.end is None else ep.end
        active = [f for f in faults if f.start - grace <= end and ep.start <= f.end + grace]
        named = ep.names()
        if any(named.intersection(f.culprits) for f in active):
            continue
        false_positives.append(FalsePositive(ep, active[0].kind if active else NO_FAULT))
    return RunScore(outcomes, tuple(false_positives))
