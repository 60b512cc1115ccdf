"""All minimal diagnoses by a breadth-first hitting-set DAG (Reiter 1987, Greiner et al. 1989).

Nodes are candidate sets Δ of abnormal components, explored level by level (|Δ| = 0, 1, …).
A node whose assignment AB(Δ) ∪ NAB(COMPS∖Δ) is consistent with Θ is a diagnosis unless a
smaller diagnosis is inside it; otherwise it is labelled with a minimal conflict K ⊆ the
assignment (a known one is reused when it fits) and gets one child Δ ∪ {c} per NAB(c) ∈ K.

Why this is complete even with fault-mode rules (AB(c) in a rule body): if a minimal
diagnosis D ⊇ Δ exists, D's assignment avoids K, and the AB literals of K are already in it
(they come from Δ ⊆ D), so some NAB(c) ∈ K has c ∈ D: one child stays below D.  A K without
NAB literals closes the node.  Breadth-first order makes the first consistent node on every
path minimal, since each smaller diagnosis was found on an earlier level.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from rac.diagnosis.engine import Base, Full, Index

Conflict = tuple[frozenset[str], frozenset[str]]  # (components assumed NAB, assumed AB)


@dataclass(frozen=True, slots=True)
class Search:
    """What one hitting-set search found."""

    diagnoses: tuple[frozenset[str], ...]
    conflicts: tuple[Conflict, ...]
    bounded: bool


class HittingSetDag:
    def __init__(self, index: Index, base: Base, full: Full, strong: bool) -> None:
        self.index = index
        self.base = base
        self.full = full
        self.strong = strong
        self.conflicts: list[Conflict] = []

    def _label(self, delta: frozenset[str]) -> Conflict | None:
        """A minimal conflict inside Δ's assignment, or None when the assignment is consistent."""
        for nab, ab in self.conflicts:  # reuse: saves a propagation over the whole model
            if nab.isdisjoint(delta) and ab <= delta:
                return nab, ab
        index = self.index
        result = index.check(self.base, self.full, delta, self.strong)
        if not result.clash:
            return None
        atoms = index.minimal_conflict(self.base, index.support(result))
        nab = frozenset(index.assumption[a][0] for a in atoms if not index.assumption[a][1])
        ab = frozenset(index.assumption[a][0] for a in atoms if index.assumption[a][1])
        self.conflicts.append((nab, ab))
        return nab, ab

    def run(self, max_card: int | None) -> Search:
        diagnoses: list[frozenset[str]] = []
        level: set[frozenset[str]] = {frozenset()}
        card = 0
        cut: set[frozenset[str]] = set()
        while level:
            children: set[frozenset[str]] = set()
            for delta in sorted(level, key=sorted):
                if any(d <= delta for d in diagnoses):
                    continue
                label = self._label(delta)
                if label is None:
                    diagnoses.append(delta)
                    continue
                for comp in label[0]:
                    children.add(delta | {comp})
            card += 1
            if max_card is not None and card > max_card:
                cut = children
                break
            level = children
        bounded = any(not any(d <= child for d in diagnoses) for child in cut)
        return Search(tuple(diagnoses), tuple(self.conflicts), bounded)


def minimal_sets(sets: Sequence[frozenset[str]]) -> list[frozenset[str]]:
    """The subset-minimal members, without duplicates."""
    unique = sorted(set(sets), key=lambda s: (len(s), sorted(s)))
    kept: list[frozenset[str]] = []
    for s in unique:
        if not any(k <= s for k in kept):
            kept.append(s)
    return kept


def transversals(edges: Sequence[frozenset[str]]) -> list[frozenset[str]]:
    """All minimal hitting sets of ``edges`` (Berge's incremental algorithm).

    Used for duality: the minimal conflicts are the minimal hitting sets of the minimal
    diagnoses, so once every diagnosis is known the conflicts follow without more checks.
    """
    current: list[frozenset[str]] = [frozenset()]
    for edge in minimal_sets(edges):
        grown: list[frozenset[str]] = []
        for t in current:
            if t & edge:
                grown.append(t)
            else:
                grown.extend(t | {e} for e in edge)
        current = minimal_sets(grown)
    return current
