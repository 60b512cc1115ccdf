"""``racc evaluate``: candidate models against test runs with known faults (§10.2).

Every model replays every test run; each run is scored against its ground truth
(:mod:`rac.evaluate.score`).  The result holds what Tables 10.1 and 10.2 and §10.2.3's
per-fault table show, and the comparison of the best model with the worst.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from rac.evaluate.parallel import run_all
from rac.evaluate.score import DEFAULT_GRACE_S, FalsePositive, FaultOutcome, RunScore, score_run
from rac.replay.engine import ReplayOptions, replay
from rac.replay.load import Replayable
from rac.replay.sources import RunInputs
from rac.synth.truth import InjectedFault

KIND_ORDER = ("slip", "cpu", "mem", "freq", "crash")


@dataclass(frozen=True, slots=True)
class Candidate:
    """A model under evaluation; ``q``/``alpha`` when it was learned in the grid."""

    label: str  # M1, M2, … or the file name
    source: str
    model: Replayable
    q: float | None = None
    alpha: float | None = None


@dataclass(frozen=True, slots=True)
class TestRun:
    path: str
    inputs: RunInputs
    faults: tuple[InjectedFault, ...]
    duration: float = 0.0  # seconds replayed (the recording's)


@dataclass(frozen=True, slots=True)
class ModelResult:
    candidate: Candidate
    observers: dict[str, int]  # kind -> count (Table 10.1)
    outcomes: tuple[tuple[str, FaultOutcome], ...]  # (run, outcome), runs in order
    false_positives: tuple[tuple[str, FalsePositive], ...]
    healthy_s: float = 0.0  # seconds of the runs outside every fault's window
    false_s: float = 0.0  # seconds of false episodes

    @property
    def vector(self) -> tuple[int, ...]:
        """1 for each correctly reported fault, 0 for each missed one (§10.2.3)."""
        return tuple(int(o.reported) for _, o in self.outcomes)

    def count(self, what: str, kind: str) -> int:
        if what == "CR":
            return sum(o.reported for _, o in self.outcomes if o.fault.kind == kind)
        if what == "FN":
            return sum(not o.reported for _, o in self.outcomes if o.fault.kind == kind)
        if what == "IS":
            return sum(o.isolated for _, o in self.outcomes if o.fault.kind == kind)
        return sum(1 for _, fp in self.false_positives if fp.kind == kind)

    def latencies(self, kind: str | None = None) -> list[float]:
        """The detection latencies, of one kind of fault or of all."""
        return [
            o.latency
            for _, o in self.outcomes
            if o.latency is not None and (kind is None or o.fault.kind == kind)
        ]

    @property
    def false_per_hour(self) -> float | None:
        """False episodes per hour of healthy recording (None: no healthy recording)."""
        return len(self.false_positives) * 3600 / self.healthy_s if self.healthy_s else None

    @property
    def false_time_per_hour(self) -> float | None:
        """Seconds of false episodes per hour of healthy recording."""
        return self.false_s * 3600 / self.healthy_s if self.healthy_s else None


@dataclass(frozen=True, slots=True)
class Evaluation:
    results: tuple[ModelResult, ...]
    runs: tuple[TestRun, ...]
    grace: float

    @property
    def kinds(self) -> tuple[str, ...]:
        """Fault kinds in the thesis's order, then any others, then ``none`` if it occurs."""
        present = {f.kind for r in self.runs for f in r.faults}
        kinds = [k for k in KIND_ORDER if k in present]
        kinds += sorted(present - set(KIND_ORDER))
        if any(fp.kind not in present for m in self.results for _, fp in m.false_positives):
            kinds.append("none")
        return tuple(kinds)


def observer_counts(model: Replayable) -> dict[str, int]:
    counts: dict[str, int] = {}
    for spec in model.specs:
        key = spec.kind
        if spec.kind == "PObs":
            prop = dict(spec.params).get("property")
            key = f"PObs_{prop}"
        counts[key] = counts.get(key, 0) + 1
    return counts


def evaluate(
    candidates: Sequence[Candidate],
    runs: Sequence[TestRun],
    options: ReplayOptions | None = None,
    grace: float = DEFAULT_GRACE_S,
    jobs: int = 1,
) -> Evaluation:
    """Every candidate over every run, on up to ``jobs`` cores."""
    replay_options = options or ReplayOptions()

    def one(pair: tuple[int, int]) -> RunScore:
        c, r = candidates[pair[0]], runs[pair[1]]
        timeline = replay(
            c.model.specs,
            c.model.theory,
            r.inputs.events,
            r.duration or r.inputs.duration,
            replay_options,
        )
        return score_run(timeline, r.faults, grace)

    pairs = [(i, j) for i in range(len(candidates)) for j in range(len(runs))]
    scores = dict(zip(pairs, run_all(one, pairs, jobs), strict=True))
    results = []
    for i, c in enumerate(candidates):
        outcomes = tuple((r.path, o) for j, r in enumerate(runs) for o in scores[(i, j)].outcomes)
        fps = tuple(
            (r.path, fp) for j, r in enumerate(runs) for fp in scores[(i, j)].false_positives
        )
        healthy = sum(scores[(i, j)].healthy_s for j in range(len(runs)))
        false_s = sum(scores[(i, j)].false_s for j in range(len(runs)))
        results.append(ModelResult(c, observer_counts(c.model), outcomes, fps, healthy, false_s))
    return Evaluation(tuple(results), tuple(runs), grace)
