"""From judged candidates to ``relate`` declarations, one per pair of fields.

A field pair may be a candidate raw, or with one side integrated.  Each field pair becomes one
``relate`` line: raw when the raw trends held, otherwise with the integrated side of its
best variant written ``I(...)`` (the binary qualitative observer integrates that side).  Its
comment gives its reading (what it means), its evidence and its held-out result.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from rac.ir import FieldRef
from rac.learn.candidates import UNEXPLAINED, Candidate, Reading
from rac.learn.correlate import Pooled
from rac.learn.holdout import HeldOut


@dataclass(frozen=True, slots=True)
class Judged:
    """A candidate with its evidence and verdicts (one per split of the recordings)."""

    candidate: Candidate
    whole: Pooled  # over every block of the first split
    verdicts: tuple[HeldOut, ...]
    family: int  # the candidates of its Holm family
    why_not: str = ""  # empty when kept

    @property
    def kept(self) -> bool:
        return not self.why_not

    @property
    def text(self) -> str:
        return f"{self.candidate.a.text} ~ {self.candidate.b.text}"

    def evidence(self) -> str:
        w = self.whole
        return (
            f"trend match ratio {self.text}: {w.ratio:.2f} ({round(w.ratio * w.checks)}/"
            f"{w.checks} checks while a side moves, chance {w.chance:.2f})"
        )


@dataclass(frozen=True, slots=True)
class LearnedRelation:
    a: tuple[str, str]  # (topic, field)
    b: tuple[str, str]
    variants: tuple[Judged, ...]  # best first

    @property
    def best(self) -> Judged:
        return self.variants[0]

    @property
    def reading(self) -> Reading:
        return self.best.candidate.reading

    @property
    def integrated(self) -> bool:
        """Only held with one side integrated (variants are raw first)."""
        c = self.best.candidate
        return c.a.integrated or c.b.integrated

    def sides(self) -> tuple[FieldRef, FieldRef]:
        """What to declare: ``a`` and ``b``, the side the best variant integrates as I()."""
        c = self.best.candidate
        integrated = {(s.topic, s.field) for s in (c.a, c.b) if s.integrated}
        return (
            FieldRef(*self.a, integrated=self.a in integrated),
            FieldRef(*self.b, integrated=self.b in integrated),
        )

    def declaration(self) -> str:
        a, b = self.sides()
        return f"relate {a.text} ~ {b.text}"

    def comments(self) -> tuple[str, ...]:
        """The reading, the evidence of every variant, the held-out result."""
        r = self.reading
        if r.kind == UNEXPLAINED:
            reading = "unexplained: neither the graph nor the message types say why; review it"
        else:
            reading = f"{r.kind}: {r.text}"
        evidence = "; ".join(v.evidence() for v in self.variants)
        best = self.best
        held = "; ".join(v.comment() for v in best.verdicts) if best.verdicts else ""
        out = [reading, evidence]
        if held:
            splits = len(best.verdicts)
            out.append(held + (f"; stable under {splits} splits" if splits > 1 else ""))
        return tuple(out)

    def evidence(self) -> str:
        return "; ".join(v.evidence() for v in self.variants)


def group_relations(kept: Sequence[Judged]) -> list[LearnedRelation]:
    groups: dict[tuple[tuple[str, str], tuple[str, str]], list[Judged]] = {}
    for j in kept:
        c = j.candidate
        x, y = (c.a.topic, c.a.field), (c.b.topic, c.b.field)
        key = (x, y) if x <= y else (y, x)
        groups.setdefault(key, []).append(j)
    out = []
    for (a, b), variants in sorted(groups.items()):
        # Raw first (what the observer checks without integrating), then by evidence.
        ordered = sorted(
            variants,
            key=lambda v: (v.candidate.a.integrated or v.candidate.b.integrated, -v.whole.z),
        )
        out.append(LearnedRelation(a, b, tuple(ordered)))
    return out
