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

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from rac.diagnosis.engine import ASSUMED, Base, Full, Index

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
        component = index.component
        nab = frozenset(component[a] for a in atoms if not index.is_ab(a))
        ab = frozenset(component[a] for a in atoms if index.is_ab(a))
        self.conflicts.append((nab, ab))
        return nab, ab

    def necessary(self) -> frozenset[str]:
        """The components c for which NAB(c) alone contradicts Θ: in every diagnosis.

        Read off the all-normal closure: a contradiction derived from a single assumption
        NAB(c) is the minimal conflict {c}.  When every component is down (a power-up),
        this finds all of them in one pass instead of one search level per component.
        """
        index, why = self.index, self.full.why
        found: set[str] = set()
        for clash in self.full.clashes:
            assumed = _assumptions(why, index.body, clash, limit=2)
            if len(assumed) == 1:
                found.add(index.component[assumed.pop()])
        return frozenset(found)

    def run(self, max_card: int | None) -> Search:
        diagnoses: list[frozenset[str]] = []
        necessary = self.necessary()
        singletons = [(frozenset([c]), frozenset[str]()) for c in sorted(necessary)]
        # every node below contains them, so they never label one: not kept for reuse
        level: set[frozenset[str]] = {necessary}
        card = len(necessary)
        cut: set[frozenset[str]] = set()
        while level:
            if max_card is not None and card > max_card:
                cut = level
                break
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
            level = children
        bounded = any(not any(d <= child for d in diagnoses) for child in cut)
        return Search(tuple(diagnoses), (*singletons, *self.conflicts), bounded)


def _assumptions(
    why: Mapping[int, int], body: Sequence[Sequence[int]], clash: tuple[int, ...], limit: int
) -> set[int]:
    """The assumption atoms ``clash`` was derived from, traced until ``limit`` are found."""
    found: set[int] = set()
    seen: set[int] = set()
    stack = list(clash)
    while stack and len(found) < limit:
        a = stack.pop()
        if a in seen:
            continue
        seen.add(a)
        k = why.get(a)
        if k is None:  # true in the base: follows from Θ alone
            continue
        if k == ASSUMED:
            found.add(a)
        else:
            stack.extend(body[k])
    return found


def minimal_sets(sets: Sequence[frozenset[str]]) -> list[frozenset[str]]:
    """The subset-minimal members, without duplicates."""
    unique = sorted(set(sets), key=lambda s: (len(s), sorted(s)))
    if unique and not unique[0]:
        return unique[:1]  # the empty set is inside every other
    kept: list[frozenset[str]] = []
    singles: set[str] = set()  # the kept singletons' members: one look-up, not a scan
    larger: list[frozenset[str]] = []
    for s in unique:
        if not s.isdisjoint(singles) or any(k <= s for k in larger):
            continue
        kept.append(s)
        if len(s) == 1:
            singles |= s
        else:
            larger.append(s)
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
