"""The units the clause index is made of, each on its own (issue 24): atom numbering,
propagation, the DRed check and the support trace, on a small hand-traced theory.

The theory: a chain NAB(a), ok(in) -> ok(m); NAB(b), ok(m) -> ok(out); a second way to
ok(out) through NAB(c), ok(in); and a fault mode AB(a) -> not_ok(m).
"""

from __future__ import annotations

from collections import ChainMap
from itertools import combinations

import pytest

from rac.diagnosis import Literal, Theory
from rac.diagnosis.dred import check
from rac.diagnosis.numbering import AtomNumbering
from rac.diagnosis.propagation import ASSUMED, Propagation
from rac.diagnosis.support import (
    assumptions_behind,
    assumptions_of_one_derivation,
    minimal_conflict,
    necessary,
)
from rac.diagnosis.theory import components_of
from rac.errors import RacError
from rac.logic import Atom, Clause


def _ok(x: str) -> Atom:
    return Atom("ok", (x,))


def _nab(c: str) -> Atom:
    return Atom("NAB", (c,))


CLAUSES = (
    Clause((_nab("a"), _ok("in")), _ok("m")),
    Clause((_nab("b"), _ok("m")), _ok("out")),
    Clause((_nab("c"), _ok("in")), _ok("out")),
    Clause((Atom("AB", ("a",)),), Atom("not_ok", ("m",))),
)
THEORY = Theory(CLAUSES, (_ok("in"), _ok("m"), _ok("out")), components_of(CLAUSES))
SYMPTOM = (Literal(_ok("in"), True), Literal(_ok("out"), False))


@pytest.fixture
def numbering() -> AtomNumbering:
    return AtomNumbering(THEORY)


def test_numbering_names_every_atom_and_its_complement(numbering: AtomNumbering) -> None:
    keys = numbering.keys
    assert len(keys) == numbering.count == len(numbering.complement)
    for a, key in enumerate(keys):
        assert numbering.number(key) == a
        assert numbering.complement[numbering.complement[a]] == a
    ok_m = numbering.atom_id(_ok("m"))
    assert ok_m is not None and keys[numbering.complement[ok_m]] == ("not_ok", ("m",))
    assert [keys[a] for a in numbering.all_nab] == [("NAB", (c,)) for c in "abc"]
    assert all(numbering.is_ab(numbering.ab_id[c]) for c in "abc")
    assert not any(numbering.is_ab(a) for a in numbering.all_nab)


def test_numbering_converts_observations(numbering: AtomNumbering) -> None:
    observed = numbering.observed(SYMPTOM)
    assert [numbering.keys[a] for a in observed] == [("ok", ("in",)), ("not_ok", ("out",))]
    assert numbering.plain_ids([("", "ok", "in"), ("not ", "ok", "out")]) == observed
    assert numbering.plain_ids([("", "ok", "nowhere")]) is None
    twice = [observed[1], observed[0], numbering.complement[observed[1]]]
    assert numbering.collect_ids(twice) == [observed[0], numbering.complement[observed[1]]]
    with pytest.raises(RacError) as err:
        numbering.observed((Literal(_ok("nowhere"), True),))
    assert err.value.diagnostics[0].code == "RAC040"
    seeds = numbering.assignment(frozenset({"b"}), strong=True)
    assert seeds == [numbering.nab_id["a"], numbering.nab_id["c"], numbering.ab_id["b"]]


def test_observations_beyond_the_props_are_converted_one_by_one() -> None:
    """Θ is looked up in a table of the props alone; an observation of an atom the rules
    mention but the props do not, of one named only by its negation, or of an assumption,
    takes the literal-by-literal path, with the same answer or error."""
    mentioned_negation = Clause((_nab("a"),), Atom("not_seen", ("x",)))
    clauses = (*CLAUSES, mentioned_negation)
    numbering = AtomNumbering(Theory(clauses, (_ok("in"),), components_of(clauses)))
    mixed = (
        Literal(_ok("in"), False),  # a prop
        Literal(_ok("m"), True),  # mentioned by the rules only
        Literal(_ok("out"), False),
        Literal(Atom("seen", ("x",)), False),  # only its negation is mentioned
        Literal(_ok("in"), True),
    )
    found = numbering.observed(mixed)
    assert found == [numbering.literal_atom(lit) for lit in mixed]
    assert [numbering.keys[a] for a in found] == [
        ("not_ok", ("in",)),
        ("ok", ("m",)),
        ("not_ok", ("out",)),
        ("not_seen", ("x",)),
        ("ok", ("in",)),
    ]
    for wrong in (Literal(_nab("a"), True), Literal(Atom("seen", ("y",)), False)):
        with pytest.raises(RacError) as err:
            numbering.observed((Literal(_ok("in"), True), wrong))
        assert err.value.diagnostics[0].code == "RAC040"


def test_propagation_closes_and_finds_the_contradiction(numbering: AtomNumbering) -> None:
    propagation = Propagation(numbering)
    assert not propagation.monotone  # AB(a) derives not_ok(m)
    base, clash = propagation.base_ids(numbering.observed(SYMPTOM))
    assert clash == ()
    full = propagation.full(base)
    ok_out = numbering.atom_id(_ok("out"))
    assert ok_out is not None and full.true[ok_out]
    assert len(full.clashes) == 1 and ok_out in full.clashes[0]
    assert all(full.why[a] == ASSUMED for a in numbering.all_nab)
    assert not propagation.consistent_ids(numbering.observed(SYMPTOM))
    assert propagation.consistent_ids(numbering.observed(SYMPTOM[:1]))
    run = propagation.run(base, [numbering.nab_id["a"], numbering.nab_id["b"]])
    assert run.clash and not propagation.run(base, [numbering.nab_id["a"]]).clash


def test_dred_check_agrees_with_a_propagation_per_candidate(numbering: AtomNumbering) -> None:
    propagation = Propagation(numbering)
    base, _ = propagation.base_ids(numbering.observed(SYMPTOM))
    full = propagation.full(base)
    for size in range(4):
        for bad in map(frozenset, combinations("abc", size)):
            for strong in (True, False):
                incremental = check(propagation, base, full, bad, strong)
                whole = propagation.run(base, numbering.assignment(bad, strong))
                assert bool(incremental.clash) == bool(whole.clash), (bad, strong)


def test_support_trace_and_conflicts(numbering: AtomNumbering) -> None:
    propagation = Propagation(numbering)
    base, _ = propagation.base_ids(numbering.observed(SYMPTOM))
    full = propagation.full(base)
    (clash,) = full.clashes
    nab = numbering.nab_id
    behind = assumptions_behind(clash, full.why, propagation.body)
    assert behind in ({nab["a"], nab["b"]}, {nab["c"]})  # the derivation the closure took
    split = ChainMap({}, full.why)  # a check's view: read map by map, same answer
    assert assumptions_behind(clash, split, propagation.body) == behind
    assert len(assumptions_behind(clash, full.why, propagation.body, limit=1)) == 1
    # ok(out) has two derivations: no single one is needed by all
    assert assumptions_of_one_derivation(clash, full, propagation.body, propagation.by_head) is None
    every = sorted(numbering.all_nab)
    assert necessary(propagation, base, every, every) == frozenset()
    one_way = [nab["a"], nab["b"]]
    assert necessary(propagation, base, one_way, one_way) == frozenset(one_way)
    assert minimal_conflict(propagation, base, frozenset(every)) in (
        frozenset(one_way),
        frozenset({nab["c"]}),
    )
