"""The engine against a brute-force reference on random small theories (hypothesis).

The reference enumerates every Δ ⊆ COMPS and decides consistency by naive fixpoint
iteration, straight from Definitions 3.32 and 3.33; it shares no code with the engine.
"""

from __future__ import annotations

from itertools import combinations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rac.diagnosis import Literal, Theory, collect, compile_theory, diagnose, is_consistent
from rac.diagnosis.theory import components_of
from rac.logic import Atom, Clause

COMPS = ("c0", "c1", "c2", "c3")
PROPS = ("p0", "p1", "p2")


def _atom(text: str) -> Atom:
    pred, _, arg = text.partition(":")
    return Atom(pred, (arg,)) if arg else Atom(pred)


def _assumptions(fault_modes: bool) -> list[str]:
    atoms = [f"NAB:{c}" for c in COMPS]
    return atoms + [f"AB:{c}" for c in COMPS] if fault_modes else atoms


PROP_ATOMS = [*PROPS, *(f"not_{p}" for p in PROPS)]
PROP_CHOICES = PROP_ATOMS + [""] * len(PROP_ATOMS)  # "": no body prop, so bodies stay short


def _heads(fault_modes: bool) -> list[str]:
    heads = [*PROP_ATOMS, "false"]
    return heads + [f"NAB:{c}" for c in COMPS[:2]] if fault_modes else heads


def _pick_two(items: list[str], n: int) -> list[str]:
    """One or two items from a single integer: fewer draws keep hypothesis fast."""
    return list(dict.fromkeys((items[n // len(items)], items[n % len(items)])))


def _clause(assumptions: list[str], heads: list[str], a: int, p: int, h: int) -> Clause:
    props = [x for x in _pick_two(PROP_CHOICES, p) if x]
    body = _pick_two(assumptions, a) + props
    return Clause(tuple(_atom(x) for x in body), _atom(heads[h]))


def theories(fault_modes: bool) -> st.SearchStrategy[Theory]:
    """Clauses over a few components and propositions, dense enough to clash often.

    With ``fault_modes`` the bodies may hold AB(c), a head may be NAB(c), and one to three
    fault-mode rules ``AB(c) -> head`` are added.
    """
    assumptions, heads = _assumptions(fault_modes), _heads(fault_modes)
    mode_heads = [*PROP_ATOMS, f"NAB:{COMPS[0]}"]
    clause = st.builds(
        lambda a, p, h: _clause(assumptions, heads, a, p, h),
        st.integers(0, len(assumptions) ** 2 - 1),
        st.integers(0, len(PROP_CHOICES) ** 2 - 1),
        st.integers(0, len(heads) - 1),
    )
    mode = st.builds(
        lambda c, h: Clause((Atom("AB", (COMPS[c],)),), _atom(mode_heads[h])),
        st.integers(0, len(COMPS) - 1),
        st.integers(0, len(mode_heads) - 1),
    )
    modes = st.lists(mode, min_size=1, max_size=3) if fault_modes else st.just([])

    def build(clauses: list[Clause], extra: list[Clause]) -> Theory:
        unique = tuple(dict.fromkeys([*clauses, *extra]))
        return Theory(unique, tuple(Atom(p) for p in PROPS), components_of(unique))

    return st.builds(build, st.lists(clause, min_size=3, max_size=10), modes)


observations = st.lists(
    st.builds(lambda p, pos: Literal(Atom(p), pos), st.sampled_from(PROPS), st.booleans()),
    min_size=2,
    max_size=5,
).map(collect)


def _closure_clashes(theory: Theory, facts: set[Atom]) -> bool:
    true = set(facts)
    changed = True
    while changed:
        changed = False
        for clause in theory.clauses:
            if clause.head not in true and all(a in true for a in clause.body):
                true.add(clause.head)
                changed = True
    if Atom("false") in true:
        return True
    for atom in true:
        if atom.predicate == "NAB" and Atom("AB", atom.args) in true:
            return True
        if Atom("not_" + atom.predicate, atom.args) in true:
            return True
    return False


def _theta(obs: tuple[Literal, ...]) -> set[Atom]:
    return {o.atom if o.positive else Atom("not_" + o.atom.predicate, o.atom.args) for o in obs}


def _subsets(items: tuple[str, ...]) -> list[frozenset[str]]:
    return [frozenset(s) for k in range(len(items) + 1) for s in combinations(items, k)]


def reference(
    theory: Theory, obs: tuple[Literal, ...]
) -> tuple[list[tuple[str, ...]], list[tuple[str, ...]]]:
    """(all minimal diagnoses, all minimal conflicts), each sorted as the engine sorts."""
    comps = theory.components
    theta = _theta(obs)

    def consistent(bad: frozenset[str]) -> bool:
        assumed = {Atom("AB", (c,)) for c in bad} | {
            Atom("NAB", (c,)) for c in comps if c not in bad
        }
        return not _closure_clashes(theory, theta | assumed)

    def conflict(nab: frozenset[str]) -> bool:
        return _closure_clashes(theory, theta | {Atom("NAB", (c,)) for c in nab})

    good = [d for d in _subsets(comps) if consistent(d)]
    diagnoses = [d for d in good if not any(o < d for o in good)]
    bad = [c for c in _subsets(comps) if conflict(c)]
    conflicts = [c for c in bad if not any(o < c for o in bad)]

    def order(sets: list[frozenset[str]]) -> list[tuple[str, ...]]:
        return sorted((tuple(sorted(s)) for s in sets), key=lambda s: (len(s), s))

    return order(diagnoses), order(conflicts)


def _agree(theory: Theory, obs: tuple[Literal, ...]) -> None:
    diagnoses, conflicts = reference(theory, obs)
    result = diagnose(theory, obs)
    assert list(result.diagnoses) == diagnoses
    assert result.consistent == (diagnoses == [()])
    assert is_consistent(theory, obs) == result.consistent
    assert list(result.conflicts) == conflicts
    for d in result.diagnoses:
        assert set(d) | set(result.good(d)) == set(theory.components)


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(theories(fault_modes=False), observations)
def test_agrees_with_brute_force_on_correct_behaviour_models(
    theory: Theory, obs: tuple[Literal, ...]
) -> None:
    _agree(theory, obs)


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(theories(fault_modes=True), observations)
def test_agrees_with_brute_force_with_fault_modes(theory: Theory, obs: tuple[Literal, ...]) -> None:
    _agree(theory, obs)


@settings(max_examples=80, deadline=None)
@given(theories(fault_modes=True), observations, st.integers(0, 3))
def test_max_card_keeps_exactly_the_small_diagnoses(
    theory: Theory, obs: tuple[Literal, ...], max_card: int
) -> None:
    diagnoses, conflicts = reference(theory, obs)
    result = diagnose(theory, obs, max_card)
    assert set(result.conflicts) <= set(conflicts)  # found ones are minimal conflicts
    assert list(result.diagnoses) == [d for d in diagnoses if len(d) <= max_card]
    if any(len(d) > max_card for d in diagnoses):
        assert result.bounded
    if not result.bounded:
        assert list(result.diagnoses) == diagnoses


@settings(max_examples=100, deadline=None)
@given(theories(fault_modes=True), observations, st.sets(st.sampled_from(COMPS)))
def test_incremental_check_matches_definition(
    theory: Theory, obs: tuple[Literal, ...], bad: set[str]
) -> None:
    """The delete-and-rederive check of one candidate agrees with a fixpoint from scratch."""
    index = compile_theory(theory)
    base, clash = index.base(obs)
    if clash:
        return
    delta = frozenset(bad) & set(theory.components)
    assumed = {Atom("AB", (c,)) for c in delta}
    assumed |= {Atom("NAB", (c,)) for c in theory.components if c not in delta}
    expected = not _closure_clashes(theory, _theta(obs) | assumed)
    result = index.check(base, index.full(base), delta, strong=True)
    assert (not result.clash) == expected
    if result.clash:  # the traced support is itself contradictory
        support = index.support(result)
        assert index.run(base, sorted(support)).clash
