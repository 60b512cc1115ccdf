"""The clause index numbers every atom the engine can meet, including complements nothing
mentions, which it keeps as numbers only (issue 14): checked against a reference that
spells every atom out, on random theories (hypothesis) and through the commands that read
observations.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rac.cli import main
from rac.diagnosis import Literal, Theory, diagnose, is_consistent, parse_literal
from rac.diagnosis.engine import Index
from rac.diagnosis.theory import Key, components_of, known_atoms
from rac.load.observations import parse_observations
from rac.logic import FALSE, Atom, Clause

ATOMS = [
    "NAB(a)",
    "NAB(b)",
    "AB(a)",
    "ok(x)",
    "not_ok(x)",
    "not_ok(y)",
    "p",
    "q(a,b)",
    "false",
]
ODD_ATOMS = ["not_not_r", "not_r", "r(z)", "not_not_r(z)"]  # complements that chain


def _atom(text: str) -> Atom:
    pred, _, rest = text.partition("(")
    return Atom(pred, tuple(rest.rstrip(")").split(",")) if rest else ())


def _other(pred: str) -> str:
    if pred in ("AB", "NAB"):
        return "NAB" if pred == "AB" else "AB"
    return pred.removeprefix("not_") if pred.startswith("not_") else "not_" + pred


def reference_atoms(theory: Theory) -> dict[Key, Key | None]:
    """Every atom the index must number, each with its complement's key (None for false):
    the atoms mentioned, NAB and AB of every component, and complements to a fixpoint."""
    found: dict[Key, Key | None] = {}
    todo: list[Key] = [(a.predicate, a.args) for c in theory.clauses for a in (c.head, *c.body)]
    todo += [(a.predicate, a.args) for a in theory.props]
    todo += [(p, (c,)) for c in theory.components for p in ("NAB", "AB")]
    while todo:
        key = todo.pop()
        if key in found:
            continue
        found[key] = None if key == (FALSE, ()) else (_other(key[0]), key[1])
        if found[key] is not None:
            todo.append(found[key])  # type: ignore[arg-type]
    return found


@st.composite
def theories(draw: st.DrawFn) -> Theory:
    pool = ATOMS + (ODD_ATOMS if draw(st.booleans()) else [])
    clauses = []
    for _ in range(draw(st.integers(0, 8))):
        body = draw(st.lists(st.sampled_from(pool), max_size=3, unique=True))
        clauses.append(Clause(tuple(map(_atom, body)), _atom(draw(st.sampled_from(pool)))))
    unique = tuple(dict.fromkeys(clauses))
    props = tuple(map(_atom, draw(st.lists(st.sampled_from(pool), max_size=3))))
    extra = draw(st.sampled_from([(), ("unmentioned",)]))  # a component no rule names
    return Theory(unique, props, (*components_of(unique), *extra))


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(theories())
def test_every_atom_is_numbered_once_with_its_complement(theory: Theory) -> None:
    index = Index(theory)
    expected = reference_atoms(theory)
    assert len(index.keys) == index.count == len(expected)
    assert set(index.keys) == set(expected)
    for number, key in enumerate(index.keys):
        assert index.number(key) == number
        other = expected[key]
        assert index.complement[number] == (-1 if other is None else index.number(other))
    for c in theory.components:
        assert index.keys[index.nab_id[c]] == ("NAB", (c,))
        assert index.keys[index.ab_id[c]] == ("AB", (c,))
    for absent in [("not_not_ok", ("x",)), ("not_false", ()), ("ok", ("nothing",))]:
        if absent not in expected:
            assert index.number(absent) is None


@settings(max_examples=300, deadline=None)
@given(theories())
def test_literals_and_known_atoms_agree_with_the_reference(theory: Theory) -> None:
    index = Index(theory)
    expected = reference_atoms(theory)
    candidates = [*map(_atom, ATOMS + ODD_ATOMS), *known_atoms(theory)]
    candidates += [Atom(a.predicate.removeprefix("not_"), a.args) for a in candidates]
    assert {a for a in candidates if a in index.known} == known_atoms(theory)
    for text in ATOMS + ODD_ATOMS:
        atom = _atom(text)
        for positive in (True, False):
            key = (atom.predicate, atom.args) if positive else ("not_" + atom.predicate, atom.args)
            excluded = key[0] in ("AB", "NAB") or key == (FALSE, ())
            excluded |= positive and atom.predicate.startswith("not_")
            wanted = None if excluded or key not in expected else index.number(key)
            assert index.literal_id(atom.predicate, atom.args, positive) == wanted


# Only the negation of each observed atom is mentioned: every positive observation names an
# atom that exists as a number only.
ONLY_NEGATIONS = """\
ab: AB
nab: NAB
neg_prefix: not_
props:
- not_ok(scan)
- not_ok(pose)
rules:
- NAB(laser) -> not_ok(scan)
- NAB(laser), NAB(slam) -> not_ok(pose)
"""


def _theory(tmp_path: Path) -> tuple[Path, Theory]:
    from rac.load.theory import load_theory

    path = tmp_path / "model.yaml"
    path.write_text(ONLY_NEGATIONS, encoding="utf-8")
    return path, load_theory(str(path))


def test_observing_an_atom_only_its_negation_names(tmp_path: Path) -> None:
    _, theory = _theory(tmp_path)
    seen = parse_literal("ok(scan)", theory)
    assert seen == Literal(Atom("ok", ("scan",)), True, "not_")
    assert not is_consistent(theory, (seen,))
    assert is_consistent(theory, (parse_literal("not ok(scan)", theory),))
    result = diagnose(theory, parse_observations("ok(pose)\nnot ok(scan)\n", "o.txt", theory))
    assert result.diagnoses == (("laser",), ("slam",))


@pytest.mark.parametrize(
    ("lines", "bad"),
    [
        ("ok(scan)\nok(pose)\n", [["laser"]]),
        ("not ok(scan)\nok(pose)\n", [["laser"], ["slam"]]),
        ("not ok(scan)\nnot ok(pose)\n", [[]]),
        ("not_ok(scan)\n# a comment: the line reader\nok(pose)\n", [["laser"], ["slam"]]),
    ],
)
def test_observation_files_of_such_atoms_read_in_every_layout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], lines: str, bad: list[list[str]]
) -> None:
    model, _ = _theory(tmp_path)
    obs = tmp_path / "obs.txt"
    obs.write_text(lines, encoding="utf-8")
    code = main(["diagnose", str(model), "--obs-file", str(obs), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert [d["bad"] for d in out["diagnoses"]] == bad
    flags = [x for line in lines.splitlines() if "#" not in line for x in ("--obs", line)]
    assert main(["diagnose", str(model), *flags, "--json"]) == 0
    assert [d["bad"] for d in json.loads(capsys.readouterr().out)["diagnoses"]] == bad


def test_an_unknown_atom_is_still_reported(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model, _ = _theory(tmp_path)
    assert main(["diagnose", str(model), "--obs", "ok(map)"]) == 1
    assert "RAC040" in capsys.readouterr().err
