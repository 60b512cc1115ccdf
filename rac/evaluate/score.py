"""Scoring a replayed run against its ground truth: §10.2.2's CR, FN and FP, honestly.

- A fault is **detected** (correctly reported, CR) by a diagnosis that *starts* after the
  fault starts, no later than G seconds (the grace) after it ends, and names one of its
  culprits.  A diagnosis that was already in effect when the fault began was caused by
  something else: a false alarm that happens to name the culprit is no detection (with a
  model of one node every diagnosis names it).  Otherwise the fault is a **false
  negative** (FN).
- Its **latency** is the time from the fault's start to that diagnosis.
- It is **isolated** when, from its detection to G seconds after its end, the diagnoses
  at some time all name one of its culprits (the culprit is in every minimal diagnosis);
  its **candidates** are the minimal diagnoses at detection.
- A **false episode** (FP) is an episode (a stretch of non-empty diagnoses) that did not
  start within a fault's window (from its start to G seconds after its end) while naming
  one of that fault's culprits.  It is counted under the kind of the fault active when it
  began, or ``none``.  False episodes and their time are also reported per hour of
  healthy recording: the recording outside every fault's window.
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
    reported: bool  # detected: a diagnosis naming a culprit started within its window
    first: float | None  # when that diagnosis started
    diagnoses: tuple[tuple[str, ...], ...]  # what was diagnosed in the window
    isolated: bool = False  # at some time every minimal diagnosis named a culprit
    isolated_at: float | None = None
    candidates: int = 0  # minimal diagnoses when it was detected

    @property
    def latency(self) -> float | None:
        return None if self.first is None else self.first - self.fault.start


@dataclass(frozen=True, slots=True)
class FalsePositive:
    episode: Episode
    kind: str  # the kind of the fault active when it began, or NO_FAULT


@dataclass(frozen=True, slots=True)
class RunScore:
    outcomes: tuple[FaultOutcome, ...]
    false_positives: tuple[FalsePositive, ...]
    duration: float = 0.0  # seconds replayed
    healthy_s: float = 0.0  # of which outside every fault's window (grace included)
    false_s: float = 0.0  # seconds of false episodes


def score_fault(fault: Fault, records: Sequence[DiagnosisRecord], grace: float) -> FaultOutcome:
    culprits = set(fault.culprits)
    close = fault.end + grace
    before: frozenset[tuple[str, ...]] = frozenset()
    seen: dict[tuple[str, ...], None] = {}
    first: float | None = None
    candidates = 0
    isolated_at: float | None = None
    for r in records:
        if r.t < fault.start:
            before = frozenset(r.diagnoses)
            continue
        if r.t > close:
            break
        seen.update(dict.fromkeys(r.diagnoses))
        started = [d for d in r.diagnoses if d not in before]
        if first is None and any(culprits.intersection(d) for d in started):
            first, candidates = r.t, len(r.diagnoses)
        every = bool(r.diagnoses) and all(culprits.intersection(d) for d in r.diagnoses)
        if first is not None and isolated_at is None and every:
            isolated_at = r.t
        before = frozenset(r.diagnoses)
    return FaultOutcome(
        fault,
        first is not None,
        first,
        tuple(seen),
        isolated_at is not None,
        isolated_at,
        candidates,
    )


def _windows(faults: Sequence[Fault], grace: float, duration: float) -> float:
    """Seconds of [0, duration] inside some fault's window (its start to end + grace)."""
    spans = sorted((max(f.start, 0.0), min(f.end + grace, duration)) for f in faults)
    covered, reach = 0.0, 0.0
    for start, end in spans:
        start = max(start, reach)
        if end > start:
            covered += end - start
            reach = end
    return covered


def score_run(
    timeline: Timeline, faults: Sequence[Fault], grace: float = DEFAULT_GRACE_S
) -> RunScore:
    records = timeline.diagnoses
    outcomes = tuple(score_fault(f, records, grace) for f in faults)
    false_positives = []
    false_s = 0.0
    for ep in episodes(timeline.records):
        explained = any(
            f.start <= ep.start <= f.end + grace and ep.names().intersection(f.culprits)
            for f in faults
        )
        if explained:
            continue
        active = [f for f in faults if f.start <= ep.start <= f.end + grace]
        false_positives.append(FalsePositive(ep, active[0].kind if active else NO_FAULT))
        false_s += (timeline.duration if ep.end is None else ep.end) - ep.start
    healthy = max(timeline.duration - _windows(faults, grace, timeline.duration), 0.0)
    return RunScore(outcomes, tuple(false_positives), timeline.duration, healthy, false_s)
