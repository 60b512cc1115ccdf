"""From correlated signals to ``relate`` declarations, one per pair of fields.

Algorithm 16 may find a field pair correlated raw, or with one side integrated.  The model
language relates fields, not integrals, so each field pair becomes one ``relate`` line and
its evidence comment names every variant that matched (``I(/pose.twist.twist.angular.z)``
marks the integrated side).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

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
        return not any(not v.a.integrated and not v.b.integrated for v in self.variants)

    def evidence(self) -> str:
        parts = []
        for v in self.variants:
            parts.append(
                f"{v.a.text} ~ {v.b.text}: {v.ratio:.2f} ({v.matches}/{v.checks}, "
                f"chance {v.chance:.2f})"
            )
        note = "trend match ratio " + "; ".join(parts)
        if self.integrated:
            note += " [integrated only: the observer needs I() of that side]"
        return note


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
