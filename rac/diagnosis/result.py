"""``diagnose``: consistency, minimal conflicts and all minimal diagnoses of Θ."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import compress

from rac.diagnosis.engine import Index
from rac.diagnosis.search import HittingSetDag, minimal_sets, transversals
from rac.diagnosis.theory import Literal, Theory
from rac.perf import ByIdentity, paused_gc


@dataclass(frozen=True, slots=True)
class DiagnosisResult:
    consistent: bool
    conflicts: tuple[tuple[str, ...], ...]  # minimal conflict sets, each sorted
    diagnoses: tuple[tuple[str, ...], ...]  # all minimal diagnoses, fewest first then by name
    components: tuple[str, ...]
    bounded: bool  # True when max_card cut the search

    def good(self, bad: tuple[str, ...]) -> tuple[str, ...]:
        """COMPS minus ``bad``, sorted."""
        faulty = set(bad)
        return tuple(c for c in self.components if c not in faulty)


# The clause index of a theory, built once per theory object and then reused.
compile_theory: ByIdentity[Theory, Index] = ByIdentity(Index)


def _ordered(
    sets: Sequence[frozenset[str]], index: Index, singles: frozenset[str] = frozenset()
) -> tuple[tuple[str, ...], ...]:
    """Each set sorted, fewest members first, then by name, with a one-member set for each
    of ``singles``: tuples of one size are compared as they are, without a (size, tuple)
    key per set."""
    order = index.sorted_components
    singles = _with_members(singles, (s for s in sets if len(s) == 1))
    by_size: dict[int, list[tuple[str, ...]]] = {}
    for s in sets:
        if len(s) != 1:
            by_size.setdefault(len(s), []).append(_in_order(s, order))
    # the one-member sets are the index's own tuples: a chain's or a fan-in's n of them were
    # n new tuples per diagnosis, which the garbage collector then walked
    one = index.singleton_tuples
    if 4 * len(singles) < len(order):
        one = tuple((c,) for c in sorted(singles))
    elif len(singles) != len(order):
        one = tuple(compress(one, map(singles.__contains__, order)))
    ordered = [t for size in sorted(by_size) if size < 1 for t in by_size[size]]  # the empty set
    ordered.extend(one)
    ordered.extend(t for size in sorted(by_size) if size > 1 for t in sorted(by_size[size]))
    return tuple(ordered)


def _with_members(names: frozenset[str], sets: Iterable[frozenset[str]]) -> frozenset[str]:
    """``names`` and the members of ``sets``; ``names`` itself when they add none (no copy
    of a set of every component)."""
    more = set().union(*sets)
    return names if more <= names else names | more


def _in_order(names: frozenset[str], order: tuple[str, ...]) -> tuple[str, ...]:
    """``tuple(sorted(names))`` for a subset of ``order`` (every component, sorted): ``order``
    itself when it is all of them (a fan-in's conflict), by one pass over them for a large
    share (n look-ups, where the sort compared strings scattered over memory n log n times)."""
    if len(names) == len(order):
        return order
    if 4 * len(names) < len(order):
        return tuple(sorted(names))
    return tuple(compress(order, map(names.__contains__, order)))


def is_consistent(theory: Theory, observations: Sequence[Literal], bad: Sequence[str] = ()) -> bool:
    """Is clauses ∪ Θ ∪ AB(bad) ∪ NAB(COMPS∖bad) consistent?  One linear propagation."""
    index = compile_theory(theory)
    if not bad:
        return index.consistent(observations)
    base, clash = index.base(observations)
    if clash:
        return False
    return not index.run(base, index.assignment(frozenset(bad), strong=True)).clash


def diagnose(
    theory: Theory, observations: Sequence[Literal], max_card: int | None = None
) -> DiagnosisResult:
    """Reiter's minimal diagnoses (Definition 3.32) of Θ, searched up to ``max_card`` faults."""
    with paused_gc():  # closures of the whole model: large, short-lived and acyclic
        return _diagnose(theory, compile_theory(theory).observed_ids(observations), max_card)


def diagnose_ids(
    theory: Theory, observed: Sequence[int], max_card: int | None = None
) -> DiagnosisResult:
    """:func:`diagnose` of Θ given as atom numbers of the theory's index
    (``compile_theory(theory).observed_ids``, ``plain_ids``)."""
    with paused_gc():
        return _diagnose(theory, observed, max_card)


def _diagnose(theory: Theory, observed: Sequence[int], max_card: int | None) -> DiagnosisResult:
    index = compile_theory(theory)
    base, clash = index.base_ids(observed)
    comps = theory.components
    if clash:  # Θ contradicts the model whatever the components do: no diagnosis exists
        return DiagnosisResult(False, ((),), (), comps, False)
    full = index.full(base)  # the all-normal closure every candidate is checked against
    strong = HittingSetDag(index, base, full, strong=True).run(max_card)
    consistent = strong.consistent
    # Definition 3.33's conflicts assume only NAB; with fault-mode rules they come from the
    # weak search (no AB asserted), which is Reiter's monotone setting again.
    weak = (
        strong if index.monotone else HittingSetDag(index, base, full, strong=False).run(max_card)
    )
    if consistent:
        conflicts: list[frozenset[str]] = []
    elif weak.bounded:
        conflicts = minimal_sets([nab for nab, ab in weak.conflicts if not ab])
    else:
        conflicts = transversals(weak.larger, weak.singles)
    return DiagnosisResult(
        consistent=consistent,
        conflicts=_ordered(conflicts, index),
        diagnoses=_ordered(strong.larger, index, strong.singles),
        components=comps,
        bounded=strong.bounded,
    )
