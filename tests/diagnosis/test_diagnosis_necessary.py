"""The one-pass paths of the diagnosis engine for long conflicts (issue 27) against the
deletion and the per-candidate checks they replace, and against brute force.

``Index.necessary`` (the assumptions in every derivation of every contradiction) is compared
with a fixpoint per left-out assumption on random theories; whole diagnoses with the one-pass
paths forced on (every conflict, every label) are compared with the engine with them off, on
random chains and fan-ins with extra clauses, and on the chain against brute force.
"""

from __future__ import annotations

import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_diagnosis_bruteforce import (
    _closure_clashes,
    _theta,
    observations,
    reference,
    theories,
)

from rac.diagnosis import Literal, Theory, compile_theory, diagnose, search, support
from rac.diagnosis.engine import Index
from rac.diagnosis.theory import components_of
from rac.logic import Atom, Clause


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(st.booleans().flatmap(theories), observations, st.randoms(use_true_random=False))
def test_necessary_matches_a_fixpoint_per_left_out_assumption(
    theory: Theory, obs: tuple[Literal, ...], rng: random.Random
) -> None:
    index = Index(theory)
    base, clash = index.base(obs)
    if clash:
        return
    assumed = [a for a in index.all_nab if rng.random() < 0.8]
    assumed += [index.ab_id[c] for c in theory.components if rng.random() < 0.3]
    keys = index.keys
    atoms = {Atom(*keys[a]) for a in assumed}
    if not _closure_clashes(theory, _theta(obs) | atoms):
        return
    candidates = [a for a in assumed if rng.random() < 0.7]
    expected = {
        a
        for a in candidates
        if not _closure_clashes(theory, _theta(obs) | (atoms - {Atom(*keys[a])}))
    }
    assert index.necessary(base, assumed, candidates) == expected


def _chain(n: int, rng: random.Random, extra: int) -> tuple[Theory, tuple[Literal, ...]]:
    """A chain of n components, with ``extra`` random clauses across it (shortcuts and
    second inputs), ok(s0) observed and not ok(s_n)."""
    clauses = [
        Clause((Atom("NAB", (f"c{i}",)), Atom("ok", (f"s{i - 1}",))), Atom("ok", (f"s{i}",)))
        for i in range(1, n + 1)
    ]
    for _ in range(extra):
        i, j = sorted(rng.sample(range(n + 1), 2))
        body = [Atom("NAB", (f"d{rng.randrange(3)}",)), Atom("ok", (f"s{i}",))]
        if rng.random() < 0.5:
            body.append(Atom("ok", (f"s{rng.randrange(n + 1)}",)))
        clauses.append(Clause(tuple(body), Atom("ok", (f"s{j}",))))
    unique = tuple(dict.fromkeys(clauses))
    props = tuple(Atom("ok", (f"s{i}",)) for i in range(n + 1))
    theory = Theory(unique, props, components_of(unique))
    obs = (Literal(Atom("ok", ("s0",)), True), Literal(Atom("ok", (f"s{n}",)), False))
    return theory, obs


def _fan_in(n: int, rng: random.Random) -> tuple[Theory, tuple[Literal, ...]]:
    """n components feeding one fusion f, a random share of them twice (a spare path)."""
    clauses = [
        Clause((Atom("NAB", (f"c{i}",)), Atom("ok", (f"in{i}",))), Atom("ok", (f"t{i}",)))
        for i in range(n)
    ]
    clauses += [
        Clause((Atom("NAB", (f"p{i}",)), Atom("ok", (f"in{i}",))), Atom("ok", (f"t{i}",)))
        for i in range(n)
        if rng.random() < 0.2
    ]
    fused = (Atom("NAB", ("f",)), *(Atom("ok", (f"t{i}",)) for i in range(n)))
    clauses.append(Clause(fused, Atom("ok", ("out",))))
    props = (*(Atom("ok", (f"in{i}",)) for i in range(n)), Atom("ok", ("out",)))
    theory = Theory(tuple(clauses), props, components_of(tuple(clauses)))
    obs = tuple(Literal(Atom("ok", (f"in{i}",)), True) for i in range(n))
    return theory, (*obs, Literal(Atom("ok", ("out",)), False))


def _both_ways(
    theory: Theory, obs: tuple[Literal, ...], max_card: int | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    with monkeypatch.context() as patch:  # the one-pass paths on for every conflict and label
        patch.setattr(support, "_DELETION_ONLY", 0)
        patch.setattr(search, "_FEW_CHILDREN", 0)
        fast = diagnose(Theory(theory.clauses, theory.props, theory.components), obs, max_card)
    with monkeypatch.context() as patch:  # and off: deletion and a check per candidate
        patch.setattr(support, "_DELETION_ONLY", 10**9)
        patch.setattr(search, "_FEW_CHILDREN", 10**9)
        patch.setattr(search.HittingSetDag, "_root_label", lambda self: None)
        slow = diagnose(Theory(theory.clauses, theory.props, theory.components), obs, max_card)
    assert fast == slow


@pytest.mark.parametrize("seed", range(40))
def test_chains_and_fan_ins_diagnosed_alike_with_and_without_the_one_pass_paths(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = random.Random(seed)
    theory, obs = _chain(rng.randint(2, 40), rng, extra=rng.randint(0, 6))
    _both_ways(theory, obs, rng.choice([None, 0, 1, 2, 3]), monkeypatch)
    theory, obs = _fan_in(rng.randint(2, 40), rng)
    _both_ways(theory, obs, rng.choice([None, 0, 1, 2]), monkeypatch)


@pytest.mark.parametrize("n", [1, 5, 12])
def test_a_chain_against_brute_force(n: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every one of the n components is a single-fault diagnosis; the chain is the one
    minimal conflict (brute force over all 2**n subsets)."""
    theory, obs = _chain(n, random.Random(n), extra=0)
    monkeypatch.setattr(support, "_DELETION_ONLY", 0)
    monkeypatch.setattr(search, "_FEW_CHILDREN", 0)
    diagnoses, conflicts = reference(theory, obs)
    result = diagnose(theory, obs)
    assert list(result.diagnoses) == diagnoses == [(f"c{i}",) for i in sorted(
        range(1, n + 1), key=lambda i: f"c{i}")]  # fmt: skip
    assert list(result.conflicts) == conflicts
    assert compile_theory(theory).monotone


@pytest.mark.parametrize("shape", ["chain", "fan-in"])
def test_many_single_faults_come_out_sorted_whatever_the_order_of_comps(shape: str) -> None:
    """The single-fault diagnoses of a chain or fan-in are kept as names and put in order by
    one pass over COMPS sorted (result._in_order), not over COMPS as the theory lists them;
    the fan-in's one conflict of every component likewise."""
    theory, obs = (
        _chain(30, random.Random(1), 0) if shape == "chain" else _fan_in(30, random.Random(1))
    )
    shuffled = list(theory.components)
    random.Random(2).shuffle(shuffled)
    result = diagnose(Theory(theory.clauses, theory.props, tuple(shuffled)), obs)
    in_order = diagnose(Theory(theory.clauses, theory.props, theory.components), obs)
    assert theory.components == tuple(sorted(theory.components))
    assert result.diagnoses == in_order.diagnoses
    assert result.conflicts == in_order.conflicts
    assert sum(len(d) == 1 for d in result.diagnoses) > 20
    assert result.diagnoses == tuple(sorted(result.diagnoses, key=lambda d: (len(d), d)))
    assert all(list(c) == sorted(c) for c in result.conflicts)
    assert diagnose(Theory(theory.clauses, theory.props, tuple(shuffled)), obs, 0).diagnoses == ()


def test_one_derivation_traced_or_refused() -> None:
    """The trace behind the one-pass label of Δ = ∅ gives the assumptions of a derivation
    only when it is the only one: a spare path (a second clause deriving t0) refuses it,
    and the masks then find that NAB(c0) is not needed."""
    rng = random.Random(3)
    theory, obs = _fan_in(4, rng)
    index = Index(theory)
    base, _ = index.base(obs)
    full = index.full(base)
    (clash,) = full.clashes
    traced = support.assumptions_of_one_derivation(clash, full, index.body, index.by_head)
    assert traced == frozenset(index.all_nab)
    spare = Clause((Atom("NAB", ("p0",)), Atom("ok", ("in0",))), Atom("ok", ("t0",)))
    clauses = (*theory.clauses, spare)
    spared = Theory(clauses, theory.props, components_of(clauses))
    index = Index(spared)
    base, _ = index.base(obs)
    full = index.full(base)
    (clash,) = full.clashes
    assert support.assumptions_of_one_derivation(clash, full, index.body, index.by_head) is None
    needed = index.necessary(base, index.all_nab, index.all_nab, full)
    assert {index.component[a] for a in needed} == {"f", "c1", "c2", "c3"}
    assert diagnose(spared, obs).diagnoses == (("c1",), ("c2",), ("c3",), ("f",), ("c0", "p0"))
