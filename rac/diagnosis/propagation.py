"""LTUR propagation over a theory's numbered clauses.

Every atom, ``not_p`` included, is its own proposition; a state is contradictory when it holds
``p`` and ``not_p``, ``AB(c)`` and ``NAB(c)``, or ``false``.  Consistency is decided by
counter-based unit propagation (Dowling-Gallier / LTUR): each clause keeps the number of its
body atoms not yet true, so every clause is touched at most once per body atom, which is linear
in the size of the clause set.

Propagation always starts from a :class:`Base`, the closure of the facts and the observations
Θ without any assumption.  A run adds assumption atoms on top of it and keeps its own changes
in dictionaries, so a check that only touches a few clauses (a candidate conflict) costs only
those clauses, not the whole model.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import compress, count
from operator import not_

from rac.diagnosis.numbering import AtomNumbering

ASSUMED = -1  # justification of an atom that was assumed, not derived


@dataclass(frozen=True, slots=True)
class Base:
    """The closure of facts ∪ Θ: which atoms hold and each clause's count of missing atoms."""

    true: bytearray
    missing: list[int]


@dataclass(frozen=True, slots=True)
class Run:
    """The outcome of propagating assumptions on a base."""

    clash: tuple[int, ...]  # the contradictory atoms, () when consistent
    why: Mapping[int, int]  # atom made true beyond the base -> its clause (or ASSUMED)


@dataclass(frozen=True, slots=True)
class Full:
    """The closure of a base with every component assumed normal, kept for incremental checks."""

    true: bytearray
    missing: list[int]
    why: dict[int, int]
    clashes: tuple[tuple[int, ...], ...]  # every contradiction it holds


class Propagation:
    """Unit propagation over the clauses of an :class:`AtomNumbering`: the bases, runs and
    closures every check starts from.  Built once per theory, with each atom's clauses."""

    def __init__(self, numbering: AtomNumbering) -> None:
        self.numbering = numbering
        self.head, self.body = numbering.head, numbering.body
        self.complement, self.false_id = numbering.complement, numbering.false_id
        self.count = numbering.count
        self.all_nab = numbering.all_nab
        self.occurs = self._occurrences(self.body)
        self.size = list(map(len, self.body))
        self.facts = list(compress(count(), map(not_, self.size)))
        self._by_head: list[tuple[int, ...]] | None = None
        self.monotone = self._is_monotone(numbering.ab_ids)
        self._normal: Full | None = None

    def _occurrences(self, bodies: Sequence[Sequence[int]]) -> list[tuple[int, ...]]:
        """The clauses each atom occurs in the body of, as tuples: a tuple holds its items
        in its own block, where a list points to a second one, and on a large model the
        memory reads are most of a propagation step's cost.  Most atoms (heads,
        complements) occur in none and share one empty tuple: a list per atom is a hundred
        thousand allocations on a large model, and allocation is what scales worst there."""
        none: list[int] = []
        occurs: list[list[int]] = [none] * self.count
        for k, body in enumerate(bodies):
            for a in body:
                found = occurs[a]
                if found is none:
                    occurs[a] = [k]
                else:
                    found.append(k)
        return list(map(tuple, occurs))  # () is one object: the shared empty list stays one

    @property
    def by_head(self) -> list[tuple[int, ...]]:
        """The clauses deriving each atom (built on first use: only DRed and the traces need
        it), as tuples for the reason :meth:`_occurrences` gives."""
        if self._by_head is None:
            by_head: list[list[int]] = [[] for _ in range(self.count)]
            for k, h in enumerate(self.head):
                by_head[h].append(k)
            self._by_head = list(map(tuple, by_head))
        return self._by_head

    def _is_monotone(self, ab_ids: list[int]) -> bool:
        """True when assuming AB(c) can never matter: AB only ever blocks NAB.

        Then Reiter's theory applies as is (Theorem 3.1): diagnoses are exactly the minimal
        hitting sets of the minimal conflicts.  Fault-mode rules break this.
        """
        if not self.numbering.component.keys().isdisjoint(self.head):
            return False
        return not any(map(self.occurs.__getitem__, ab_ids))

    def base_ids(self, observed: Sequence[int]) -> tuple[Base, tuple[int, ...]]:
        """The closure of facts ∪ Θ (Θ as atom numbers), and the clash it already holds (()
        when none)."""
        true = bytearray(self.count)
        missing = list(self.size)
        seeds = [self.head[k] for k in self.facts]
        seeds.extend(observed)
        stack: list[int] = []
        clash = self.seed(true, seeds, {}, stack, stop=False)
        found = self.propagate(true, missing, stack, {}, stop=False)
        return Base(true, missing), clash or found

    def seed(
        self,
        true: bytearray,
        seeds: Iterable[int],
        why: dict[int, int],
        stack: list[int],
        stop: bool,
    ) -> tuple[int, ...]:
        """Make ``seeds`` true (pushing the new ones on ``stack``); the first clash met."""
        complement, false_id = self.complement, self.false_id
        clash: tuple[int, ...] = ()
        for a in seeds:
            if true[a]:
                continue
            true[a] = 1
            why[a] = ASSUMED
            c = complement[a]
            if not clash and (a == false_id or (c >= 0 and true[c])):
                clash = (a,) if a == false_id else (a, c)
                if stop:
                    return clash
            stack.append(a)
        return clash

    def propagate(
        self, true: bytearray, missing: list[int], stack: list[int], why: dict[int, int], stop: bool
    ) -> tuple[int, ...]:
        """Counter-based unit propagation (LTUR) from the atoms on ``stack``: the one loop.

        Every derived atom is recorded in ``why`` with its clause.  Returns the first
        contradiction met (() when none), and stops there when ``stop``.
        """
        occurs, head, complement, false_id = self.occurs, self.head, self.complement, self.false_id
        clash: tuple[int, ...] = ()
        while stack:
            a = stack.pop()
            for k in occurs[a]:
                missing[k] -= 1
                if missing[k] == 0:
                    h = head[k]
                    if true[h]:
                        continue
                    true[h] = 1
                    why[h] = k
                    c = complement[h]
                    if h == false_id or (c >= 0 and true[c]):
                        if not clash:
                            clash = (h,) if h == false_id else (h, c)
                        if stop:
                            return clash
                    stack.append(h)
        return clash

    def run(self, base: Base, seeds: Iterable[int], stop: bool = True) -> Run:
        """Propagate assumption atoms on ``base``; stop at the first contradiction.

        With ``stop=False`` the closure is computed in full and ``clash`` is the first one met.
        Works on copies of the base arrays: copying is a C-speed memcpy, far cheaper than
        per-clause dictionary look-ups when the run touches most of the model.
        """
        true = bytearray(base.true)
        why: dict[int, int] = {}
        stack: list[int] = []
        clash = self.seed(true, seeds, why, stack, stop)
        if clash and stop:
            return Run(clash, why)
        found = self.propagate(true, base.missing.copy(), stack, why, stop)
        return Run(clash or found, why)

    def full(self, base: Base) -> Full:
        """Close ``base`` under NAB(c) for every component, recording every contradiction."""
        return self.closure(base, self.all_nab)

    def closure(self, base: Base, assumed: Iterable[int]) -> Full:
        """Close ``base`` under the ``assumed`` atoms, recording every contradiction."""
        true = bytearray(base.true)
        missing = base.missing.copy()
        why: dict[int, int] = {}
        stack: list[int] = []
        self.seed(true, assumed, why, stack, stop=False)
        self.propagate(true, missing, stack, why, stop=False)
        complement, false_id = self.complement, self.false_id
        clashes: set[tuple[int, ...]] = set()
        for a in why:
            c = complement[a]
            if a == false_id:
                clashes.add((a,))
            elif c >= 0 and true[c]:
                clashes.add((min(a, c), max(a, c)))
        return Full(true, missing, why, tuple(sorted(clashes)))

    def normal(self) -> Full:
        """The closure of the facts and NAB(COMPS), without observations; computed once.

        Every consistency check of the all-normal assumption starts from it, so that a check
        costs the observations and what they add, not the whole model.
        """
        if self._normal is None:
            base, clash = self.base_ids(())
            full = self.full(base)
            # a clash of the facts alone stays in every closure: keep it with the others
            clashes = full.clashes + ((clash,) if clash else ())
            self._normal = Full(full.true, full.missing, full.why, clashes)
        return self._normal

    def consistent_ids(self, atoms: Sequence[int]) -> bool:
        """Is clauses ∪ Θ ∪ NAB(COMPS) consistent?  Θ as atom numbers; incremental on
        :meth:`normal`.

        Only the observations the all-normal closure does not already hold are propagated;
        finding them is one vectorised look-up, so a check of an expected Θ costs a few
        array operations however large Θ is.
        """
        import numpy as np  # on first use: most commands never check this way

        normal = self.normal()
        if normal.clashes:
            return False
        seeds = np.asarray(atoms, dtype=np.int64)
        held = np.frombuffer(normal.true, dtype=np.uint8)
        new = seeds[held[seeds] == 0].tolist() if seeds.size else []
        if not new:  # everything observed was already predicted
            return True
        true = bytearray(normal.true)
        stack: list[int] = []
        if self.seed(true, new, {}, stack, stop=True):
            return False
        return not self.propagate(true, normal.missing.copy(), stack, {}, stop=True)
