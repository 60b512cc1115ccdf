"""The propositional core: a clause index compiled once per theory, and LTUR propagation.

:class:`Index` puts together the units it is made of: :mod:`~rac.diagnosis.numbering`
(atoms as numbers, observations converted), :mod:`~rac.diagnosis.propagation` (bases,
runs and closures), :mod:`~rac.diagnosis.dred` (the incremental check of a candidate) and
:mod:`~rac.diagnosis.support` (the support trace, necessary assumptions, minimal
conflicts).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence

from rac.diagnosis import dred, support
from rac.diagnosis.numbering import AtomNumbering, KnownAtoms
from rac.diagnosis.propagation import ASSUMED, Base, Full, Propagation, Run
from rac.diagnosis.support import assumptions_behind, assumptions_of_one_derivation
from rac.diagnosis.theory import Key, Literal, Theory
from rac.logic import Atom
from rac.perf import paused_gc

__all__ = [
    "ASSUMED",
    "Base",
    "Full",
    "Index",
    "KnownAtoms",
    "Run",
    "assumptions_behind",
    "assumptions_of_one_derivation",
]


class Index:
    """The clause set of a theory as integer arrays, built once and reused for every check:
    its :class:`AtomNumbering` and its :class:`Propagation`, with the checks over them."""

    def __init__(self, theory: Theory) -> None:
        with paused_gc():  # hundreds of thousands of small lists and tuples, none cyclic
            self.numbering = numbering = AtomNumbering(theory)
            self.propagation = propagation = Propagation(numbering)
        self.theory = theory
        self.ids = numbering.ids
        self.mentioned, self.named, self.count = (
            numbering.mentioned,
            numbering.named,
            numbering.count,
        )
        self.complement, self.false_id = numbering.complement, numbering.false_id
        self.all_nab, self.nab_atoms, self.ab_atoms = (
            numbering.all_nab,
            numbering.nab_atoms,
            numbering.ab_atoms,
        )
        self.nab_id, self.ab_id, self.component = (
            numbering.nab_id,
            numbering.ab_id,
            numbering.component,
        )
        self.head, self.body = numbering.head, numbering.body
        self.known = numbering.known
        self.occurs, self.size, self.facts = propagation.occurs, propagation.size, propagation.facts
        self.monotone = propagation.monotone

    @functools.cached_property
    def sorted_components(self) -> tuple[str, ...]:
        """COMPS sorted by name: the order of a diagnosis's members."""
        return tuple(sorted(self.theory.components))

    @functools.cached_property
    def singleton_tuples(self) -> tuple[tuple[str], ...]:
        """``(c,)`` for each component, sorted: the one-member diagnoses a result shares."""
        return tuple((c,) for c in self.sorted_components)

    # numbering

    @property
    def keys(self) -> list[Key]:
        return self.numbering.keys

    def number(self, key: Key) -> int | None:
        return self.numbering.number(key)

    def atom_id(self, atom: Atom) -> int | None:
        return self.numbering.atom_id(atom)

    def is_ab(self, assumption: int) -> bool:
        return self.numbering.is_ab(assumption)

    def literal_id(self, predicate: str, args: tuple[str, ...], positive: bool) -> int | None:
        return self.numbering.literal_id(predicate, args, positive)

    def literal_atom(self, literal: Literal) -> int:
        return self.numbering.literal_atom(literal)

    def observed_ids(self, observations: Sequence[Literal]) -> list[int]:
        """Θ as atom ids (RacError RAC040 for an unknown atom): convert once, check often."""
        return self.numbering.observed(observations)

    def plain_ids(self, lines: Sequence[tuple[str, str, str]]) -> list[int] | None:
        return self.numbering.plain_ids(lines)

    def collect_ids(self, observed: Sequence[int]) -> list[int]:
        return self.numbering.collect_ids(observed)

    def assignment(self, bad: frozenset[str], strong: bool) -> list[int]:
        return self.numbering.assignment(bad, strong)

    # propagation

    @property
    def by_head(self) -> list[tuple[int, ...]]:
        return self.propagation.by_head

    def base(self, observations: Sequence[Literal]) -> tuple[Base, tuple[int, ...]]:
        """The closure of facts ∪ Θ, and the clash it already holds (() when none)."""
        return self.propagation.base_ids(self.numbering.observed(observations))

    def base_ids(self, observed: Sequence[int]) -> tuple[Base, tuple[int, ...]]:
        return self.propagation.base_ids(observed)

    def run(self, base: Base, seeds: Iterable[int], stop: bool = True) -> Run:
        return self.propagation.run(base, seeds, stop)

    def closure(self, base: Base, assumed: Iterable[int]) -> Full:
        return self.propagation.closure(base, assumed)

    def full(self, base: Base) -> Full:
        return self.propagation.full(base)

    def normal(self) -> Full:
        return self.propagation.normal()

    def consistent(self, observations: Sequence[Literal]) -> bool:
        """Is clauses ∪ Θ ∪ NAB(COMPS) consistent?  Incremental on :meth:`normal`."""
        return self.propagation.consistent_ids(self.numbering.observed(observations))

    def consistent_ids(self, atoms: Sequence[int]) -> bool:
        return self.propagation.consistent_ids(atoms)

    # checks and conflicts

    def check(self, base: Base, full: Full, bad: frozenset[str], strong: bool) -> Run:
        return dred.check(self.propagation, base, full, bad, strong)

    def support(self, result: Run) -> frozenset[int]:
        """The assumption atoms the contradiction of ``result`` was derived from."""
        return frozenset(assumptions_behind(result.clash, result.why, self.body))

    def necessary(
        self,
        base: Base,
        assumed: Sequence[int],
        candidates: Sequence[int],
        closure: Full | None = None,
    ) -> frozenset[int]:
        return support.necessary(self.propagation, base, assumed, candidates, closure)

    def minimal_conflict(
        self,
        base: Base,
        conflict: frozenset[int],
        needed_under: dict[frozenset[int], frozenset[int]] | None = None,
        closure: Full | None = None,
    ) -> frozenset[int]:
        return support.minimal_conflict(self.propagation, base, conflict, needed_under, closure)
