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

from collections.abc import Collection, Sequence
from dataclasses import dataclass

from rac.diagnosis.engine import Base, Full, Index
from rac.diagnosis.support import assumptions_behind, assumptions_of_one_derivation

Conflict = tuple[frozenset[str], frozenset[str]]  # (components assumed NAB, assumed AB)


@dataclass(frozen=True, slots=True)
class Search:
    """What one hitting-set search found.  The diagnoses of one component are kept as their
    names, apart from the larger ones: a chain or a fan-in of n components has n of them,
    and n one-member sets were most of the search's memory traffic at 20,000."""

    singles: frozenset[str]  # the components that are a diagnosis alone
    larger: tuple[frozenset[str], ...]  # the other diagnoses; (frozenset(),) when consistent
    conflicts: tuple[Conflict, ...]
    bounded: bool

    @property
    def consistent(self) -> bool:
        return not self.singles and self.larger == (frozenset(),)


class HittingSetDag:
    def __init__(self, index: Index, base: Base, full: Full, strong: bool) -> None:
        self.index = index
        self.base = base
        self.full = full
        self.strong = strong
        self.conflicts: list[Conflict] = []
        # a set of assumption atoms -> those in every contradiction it gives (Index.necessary)
        self.needed_under: dict[frozenset[int], frozenset[int]] = {}
        self.root_atoms: frozenset[int] | None = None  # the root's label, when read off a trace

    def _label(self, delta: frozenset[str]) -> Conflict | None:
        """A minimal conflict inside Δ's assignment, or None when the assignment is consistent."""
        for nab, ab in self.conflicts:  # reuse: saves a propagation over the whole model
            if nab.isdisjoint(delta) and ab <= delta:
                return nab, ab
        index = self.index
        atoms = self._root_label() if not delta else None
        if atoms is None:
            result = index.check(self.base, self.full, delta, self.strong)
            if not result.clash:
                return None
            support = index.support(result)
            # under every component's NAB, the closure is the all-normal one already computed
            closure = self.full if support == index.nab_atoms else None
            atoms = index.minimal_conflict(self.base, support, self.needed_under, closure)
        component = index.component
        # Δ = ∅ assumes no AB: nothing to take out of a conflict of every component
        ab_atoms = atoms.intersection(index.ab_atoms) if delta else frozenset[int]()
        nab_atoms = atoms.difference(ab_atoms) if ab_atoms else atoms
        nab = frozenset(map(component.__getitem__, nab_atoms))
        ab = frozenset(map(component.__getitem__, ab_atoms))
        self.conflicts.append((nab, ab))
        return nab, ab

    def _root_label(self) -> frozenset[int] | None:
        """The label of Δ = ∅ read off the all-normal closure, when it holds one contradiction
        derived one way only (a chain, a fan-in): the assumptions of that derivation, each
        needed, so a minimal conflict, and all a child's check needs to know (one trace
        where the check, its support and its shrinking took three).  None otherwise."""
        full, index = self.full, self.index
        if len(full.clashes) != 1:
            return None
        traced = assumptions_of_one_derivation(full.clashes[0], full, index.body, index.by_head)
        if traced is None:
            return None
        atoms = traced
        self.needed_under[index.nab_atoms] = self.root_atoms = atoms
        return atoms

    def necessary(self) -> frozenset[str]:
        """The components c for which NAB(c) alone contradicts Θ: in every diagnosis.

        Read off the all-normal closure: a contradiction derived from a single assumption
        NAB(c) is the minimal conflict {c}.  When every component is down (a power-up),
        this finds all of them in one pass instead of one search level per component.
        """
        index, why = self.index, self.full.why
        found: set[str] = set()
        for clash in self.full.clashes:
            assumed = assumptions_behind(clash, why, index.body, limit=2)
            if len(assumed) == 1:
                found.add(index.component[assumed.pop()])
        return frozenset(found)

    def _consistent_children(self, delta: frozenset[str], label: Conflict) -> frozenset[str]:
        """The components c of ``label`` whose child Δ ∪ {c} is consistent, known without a
        check each: when AB never matters (a monotone index), Δ ∪ {c} is consistent exactly
        when NAB(c) is in every derivation of every contradiction under NAB(COMPS∖Δ), which
        :meth:`Index.necessary` finds for all of them in one pass.  A label this small is
        left to the checks, each as long as its component's cone.
        """
        index = self.index
        if not index.monotone or len(label[0]) < _FEW_CHILDREN:
            return frozenset()
        assumed = index.assignment(delta, strong=False) if delta else index.all_nab
        # the label's own shrinking may have found them under the same assumptions (Δ = ∅
        # and a conflict of every component: a chain, a fan-in); those of the candidates
        # are the answer, as a candidate's bit is the same in either pass
        # (for Δ = ∅ the set itself: its hash is kept, and it is found by identity)
        needed = self.needed_under.get(frozenset(assumed) if delta else index.nab_atoms)
        if needed is not None and needed is self.root_atoms:
            return label[0]  # the root's label is that derivation's assumptions: all needed
        if needed is not None:
            return frozenset(c for c in label[0] if index.nab_id[c] in needed)
        candidates = [index.nab_id[c] for c in sorted(label[0])]
        found = index.necessary(self.base, assumed, candidates)
        return frozenset(index.component[a] for a in found)

    def run(self, max_card: int | None) -> Search:
        found = _Diagnoses()
        necessary = self.necessary()
        singletons = [(frozenset([c]), frozenset[str]()) for c in sorted(necessary)]
        # every node below contains them, so they never label one: not kept for reuse
        level: set[frozenset[str]] = {necessary}
        card = len(necessary)
        cut: set[frozenset[str]] = set()
        consistent: set[frozenset[str]] = set()  # children known consistent without a check
        while level:
            if max_card is not None and card > max_card:
                cut = level
                break
            children: set[frozenset[str]] = set()
            # A node known consistent is a diagnosis unless an earlier level's is inside it
            # (the nodes of a level are all of one size); it needs no label, so the order
            # the others are labelled in, which decides the conflicts reused, is unchanged
            # when they are taken first and unsorted (the n nodes below a chain's conflict).
            for delta in level & consistent:
                if not found.covers(delta):
                    found.add(delta)
            for delta in sorted_sets(level - consistent):
                if found.covers(delta):
                    continue
                label = self._label(delta)
                if label is None:
                    found.add(delta)
                    continue
                known = self._consistent_children(delta, label)
                if not delta and (max_card is None or max_card >= 1):
                    # the root's children are the label's components alone, and no smaller
                    # diagnosis can hold one: those known consistent are diagnoses already
                    found.add_singles(known)
                    children.update(frozenset((c,)) for c in label[0] if c not in known)
                    continue
                for comp in label[0]:
                    child = delta | {comp}
                    children.add(child)
                    if comp in known:
                        consistent.add(child)
            card += 1
            level = children
        bounded = any(not found.covers(child) for child in cut)
        return Search(found.singles, tuple(found.larger), (*singletons, *self.conflicts), bounded)


# A node labelled with fewer components has its children checked one by one (each check costs
# its component's cone); from this many on, one pass of Index.necessary over the closure.
_FEW_CHILDREN = 16


class _Diagnoses:
    """The diagnoses found so far, and whether one is inside a candidate: the single-fault
    ones by a set look-up, not a scan (a chain of n components has n)."""

    def __init__(self) -> None:
        self._single_groups: list[frozenset[str]] = []  # each a set of single-fault ones
        self._singles: set[str] = set()  # the others, found one at a time
        self.larger: list[frozenset[str]] = []

    def add(self, delta: frozenset[str]) -> None:
        if len(delta) == 1:
            self._singles |= delta
        else:
            self.larger.append(delta)

    def add_singles(self, names: frozenset[str]) -> None:
        """Each of ``names`` is a diagnosis alone: kept as the set it is (a chain's or a
        fan-in's n components, not copied member by member)."""
        self._single_groups.append(names)

    @property
    def singles(self) -> frozenset[str]:
        if not self._singles and len(self._single_groups) == 1:
            return self._single_groups[0]  # itself: the one set of them, not copied
        return frozenset().union(*self._single_groups, self._singles)

    def covers(self, delta: frozenset[str]) -> bool:
        if not self._singles.isdisjoint(delta):
            return True
        if any(not group.isdisjoint(delta) for group in self._single_groups):
            return True
        return bool(self.larger) and any(d <= delta for d in self.larger)


def sorted_sets(sets: Collection[frozenset[str]]) -> list[frozenset[str]]:
    """``sorted(sets, key=sorted)``; sets of one member by that member (a string compared,
    not a list built and compared: the n single-fault diagnoses of a chain)."""
    if all(len(s) == 1 for s in sets):
        return sorted(sets, key=min)
    return sorted(sets, key=sorted)


def minimal_sets(sets: Sequence[frozenset[str]]) -> list[frozenset[str]]:
    """The subset-minimal members, without duplicates."""
    by_size: dict[int, list[frozenset[str]]] = {}
    for s in set(sets):
        by_size.setdefault(len(s), []).append(s)
    unique = [s for size in sorted(by_size) for s in sorted_sets(by_size[size])]
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


def transversals(
    edges: Sequence[frozenset[str]], singles: frozenset[str] = frozenset()
) -> list[frozenset[str]]:
    """All minimal hitting sets of ``edges`` and of the one-member edges ``{s}`` for each
    ``s`` in ``singles`` (Berge's incremental algorithm).

    Used for duality: the minimal conflicts are the minimal hitting sets of the minimal
    diagnoses, so once every diagnosis is known the conflicts follow without more checks.
    """
    # A one-element edge is in every hitting set: taken out first, the rest is what Berge's
    # rounds grow (n single-fault diagnoses were n rounds over one growing set: quadratic).
    # An edge holding one of them is hit already; the others join each set at the end.
    singles = frozenset(singles)  # no copy of a frozenset: returned as it is, never mutable
    more = frozenset[str]().union(*(edge for edge in edges if len(edge) == 1))
    # singles itself when the edges add none: a fan-in's conflict of every component
    forced = singles if more <= singles else singles | more
    current: list[frozenset[str]] = [frozenset()]
    for edge in minimal_sets([e for e in edges if len(e) != 1 and e.isdisjoint(forced)]):
        grown: list[frozenset[str]] = []
        for t in current:
            if t & edge:
                grown.append(t)
            else:
                grown.extend(t | {e} for e in edge)
        current = minimal_sets(grown)
    return [t | forced if t else forced for t in current] if forced else current
