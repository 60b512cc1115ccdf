"""From correlated signals to ``relate`` declarations, one per pair of fields.

Algorithm 16 may find a field pair correlated raw, or with one side integrated.  Each field
pair becomes one ``relate`` line: raw when the raw trends matched, otherwise with the
integrated side of its best variant written ``I(...)`` (the binary qualitative observer
integrates that side).  Its evidence comment names every variant that matched.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from rac.ir import FieldRef
from rac.learn.correlate import Correlation


@dataclass(frozen=True, slots=True)
class LearnedRelation:
    a: tuple[str, str]  # (topic, field)
    b: tuple[str, str]
    variants: tuple[Correlation, ...]  # best first

    @property
    def best(self) -> Correlation:
        return self.variants[0]

    @property
    def integrated(self) -> bool:
        """Only matched with one side integrated (variants are raw first)."""
        return self.best.a.integrated or self.best.b.integrated

    def sides(self) -> tuple[FieldRef, FieldRef]:
        """What to declare: ``a`` and ``b``, the side the best variant integrates as I()."""
        integrated = {(s.topic, s.field) for s in (self.best.a, self.best.b) if s.integrated}
        return (
            FieldRef(*self.a, integrated=self.a in integrated),
            FieldRef(*self.b, integrated=self.b in integrated),
        )

    def declaration(self) -> str:
        a, b = self.sides()
        return f"relate {a.text} ~ {b.text}"

    def evidence(self) -> str:
        parts = []
        for v in self.variants:
            parts.append(
                f"{v.a.text} ~ {v.b.text}: {v.ratio:.2f} ({v.matches}/{v.checks}, "
                f"chance {v.chance:.2f})"
            )
        return "trend match ratio " + "; ".join(parts)


def group_relations(found: Sequence[Correlation]) -> list[LearnedRelation]:
    groups: dict[tuple[tuple[str, str], tuple[str, str]], list[Correlation]] = {}
    for c in found:
        x = (c.a.topic, c.a.field)
        y = (c.b.topic, c.b.field)
        key = (x, y) if x <= y else (y, x)
        groups.setdefault(key, []).append(c)
    out = []
    for (a, b), variants in sorted(groups.items()):
        # Raw matches first (what the observer checks), then by ratio.
        ordered = sorted(variants, key=lambda v: (v.a.integrated or v.b.integrated, -v.ratio))
        out.append(LearnedRelation(a, b, tuple(ordered)))
    return out
