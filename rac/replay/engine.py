"""Replay: observer inputs in time order -> observations (Algorithm 10) -> diagnoses.

The engine owns no clock and reads no file.  It feeds each input to the observers, lets
time pass for them between inputs (a topic that stops sends nothing, yet must be noticed),
collects their verdicts into Θ as Algorithm 10 does, and diagnoses Θ with the diagnosis
engine at a fixed period and, as the live engine does, as soon as Θ changes (no sooner than
:data:`CHANGE_GAP_S` after the last diagnosis).  Every change of Θ and of the diagnoses
becomes a timeline record.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from rac.diagnosis.result import diagnose
from rac.diagnosis.theory import Theory
from rac.observe.bank import ObserverBank
from rac.observe.collect import ObservationSet
from rac.observe.events import Event, Verdict
from rac.passes.observers import ObserverSpec
from rac.replay.timeline import Diagnoses, DiagnosisRecord, ObservationRecord, Record, Timeline

DEFAULT_DIAGNOSE_EVERY_S = 1.0
DEFAULT_ADVANCE_EVERY_S = 0.1  # how finely time passes for observers between inputs
DEFAULT_MAX_CARD = 3
# A change of Θ is diagnosed at once, but no sooner than this after the last diagnosis: the
# live engine's rule (rac.runtime.diagnoser.MIN_GAP_S), so that replay reports a fault when
# the robot would, not at the next period.
CHANGE_GAP_S = 0.2


@dataclass(frozen=True, slots=True)
class ReplayOptions:
    diagnose_every: float = DEFAULT_DIAGNOSE_EVERY_S
    advance_every: float = DEFAULT_ADVANCE_EVERY_S
    max_card: int | None = DEFAULT_MAX_CARD
    on_change: bool = True  # a changed Θ is diagnosed CHANGE_GAP_S after the last diagnosis


class _Diagnoser:
    """Minimal diagnoses of Θ, remembered per Θ: a healthy robot revisits the same sets."""

    def __init__(self, theory: Theory, max_card: int | None) -> None:
        self.theory = theory
        self.max_card = max_card
        self.memo: dict[tuple[str, ...], Diagnoses] = {}

    def __call__(self, observations: ObservationSet) -> Diagnoses:
        literals = observations.literals()
        key = tuple(str(lit) for lit in literals)
        hit = self.memo.get(key)
        if hit is None:
            result = diagnose(self.theory, literals, self.max_card)
            if not result.consistent and not result.diagnoses and result.bounded:
                # More faults than the bound at once (a robot that is down): search them
                # all rather than publish "consistent".
                result = diagnose(self.theory, literals, None)
            hit = self.memo[key] = result.diagnoses if not result.consistent else ()
        return hit


def replay(
    specs: Sequence[ObserverSpec],
    theory: Theory,
    events: Iterable[Event],
    end: float,
    options: ReplayOptions = ReplayOptions(),
    progress: Callable[[float], None] | None = None,
) -> Timeline:
    """Replay ``events`` (times in seconds from the start of the recording, in order) up to
    ``end`` through the observers of ``specs`` and the diagnosis of ``theory``."""
    bank = ObserverBank(specs)
    theta = ObservationSet()
    diagnoser = _Diagnoser(theory, options.max_card)
    records: list[Record] = []
    last: Diagnoses | None = None
    changed = True
    step, period = options.advance_every, options.diagnose_every
    gap = min(CHANGE_GAP_S, period)
    next_advance, next_diagnosis = step, period
    now = 0.0  # how far time has passed
    last_at = -math.inf  # the last diagnosis
    due = math.inf  # when the changed Θ is diagnosed (on_change)

    def take(verdicts: list[Verdict]) -> None:
        nonlocal changed, due
        for v in verdicts:
            if theta.add(v):
                changed = True
                records.append(ObservationRecord(v.t, str(v)))
                if options.on_change and due == math.inf:
                    due = max(v.t, now, last_at + gap)

    def diagnose_at(t: float) -> None:
        nonlocal last, changed, last_at, due
        if changed or last is None:
            current = diagnoser(theta)
            changed = False
            if current != last:
                records.append(DiagnosisRecord(t, current))
                last = current
        last_at, due = t, math.inf

    def catch_up(until: float) -> None:
        """Let time pass up to ``until``: advance the observers, diagnose when due."""
        nonlocal next_advance, next_diagnosis, now
        while min(next_advance, next_diagnosis, due) <= until:
            if next_advance <= min(next_diagnosis, due):
                now = next_advance
                take(bank.advance(next_advance))
                next_advance = round(next_advance + step, 9)
                continue
            if due < next_diagnosis:
                now = due
                diagnose_at(due)
                continue
            now = next_diagnosis
            diagnose_at(next_diagnosis)
            if progress is not None:
                progress(next_diagnosis)
            next_diagnosis = round(next_diagnosis + period, 9)

    for event in events:
        catch_up(event.t)
        now = max(now, event.t)
        take(bank.feed(event))
    catch_up(end)
    return Timeline(tuple(records), end)
