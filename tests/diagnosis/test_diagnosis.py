"""The dissertation's diagnosis examples (§3.4, Examples 4.5 and 6.4, §8.4) and the engine API."""

from __future__ import annotations

from pathlib import Path

import pytest

from rac.diagnosis import (
    Literal,
    Theory,
    all_single_faults,
    ambiguity_groups,
    collect,
    diagnose,
    parse_literal,
    predict,
    simulate,
)
from rac.diagnosis.theory import components_of
from rac.errors import RacError
from rac.load.model_yaml import parse_model_yaml
from rac.load.observations import parse_observations
from rac.load.theory import load_theory
from rac.logic import Atom, parse_clause

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
ADDER = ROOT / "tests" / "diagnosis" / "full_adder.yaml"
ADDER_OBS = ROOT / "tests" / "diagnosis" / "full_adder.obs"


@pytest.fixture(scope="module")
def tedusar() -> Theory:
    return load_theory(TEDUSAR)


def lits(theory: Theory, *texts: str) -> tuple[Literal, ...]:
    return collect(parse_literal(t, theory) for t in texts)


def everything_fine(theory: Theory) -> list[str]:
    return [str(a) for a in theory.props]


def test_example_4_5_stopped_imu_node(tedusar: Theory) -> None:
    theta = lits(tedusar, "ok(cmd_vel)", "running(imu_node)", "ok(hokuyo_node,cpu)")
    fine = diagnose(tedusar, theta)
    assert fine.consistent and fine.diagnoses == ((),) and fine.conflicts == ()
    stopped = collect([*theta, parse_literal("not running(imu_node)", tedusar)])
    result = diagnose(tedusar, stopped)
    assert not result.consistent
    assert result.conflicts == (("imu_node",),)
    assert result.diagnoses == (("imu_node",),)
    assert "imu_node" not in result.good(("imu_node",))
    assert set(result.good(("imu_node",))) == set(tedusar.components) - {"imu_node"}


def test_example_6_4_stopped_jaguar_node(tedusar: Theory) -> None:
    fine = lits(tedusar, *everything_fine(tedusar))
    assert diagnose(tedusar, fine).diagnoses == ((),)
    stopped = collect(
        [
            *fine,
            *lits(
                tedusar,
                "¬running(jaguar_node)",
                "not ok(jaguar_node,cpu)",
                "not_ok(jaguar_node,mem)",
            ),
        ]
    )
    result = diagnose(tedusar, stopped)
    assert result.conflicts == (("jaguar_node",),)
    assert result.diagnoses == (("jaguar_node",),)


def test_section_8_4_jaguar_or_jaguar_node(tedusar: Theory) -> None:
    healthy = lits(tedusar, "on(jaguar)", "running(jaguar_node)", "ok(pose)")
    assert diagnose(tedusar, healthy).diagnoses == ((),)
    disconnected = lits(tedusar, "on(jaguar)", "running(jaguar_node)", "not ok(pose)")
    result = diagnose(tedusar, disconnected)
    assert result.conflicts == (("jaguar", "jaguar_node"),)
    assert result.diagnoses == (("jaguar",), ("jaguar_node",))


def test_stopped_hector_mapping(tedusar: Theory) -> None:
    theta = lits(
        tedusar,
        *everything_fine(tedusar),
        "not running(hector_mapping)",
        "not ok(hector_mapping,cpu)",
        "not ok(hector_mapping,mem)",
    )
    assert diagnose(tedusar, theta).diagnoses == (("hector_mapping",),)
    sim = simulate(tedusar, ["hector_mapping"])
    assert sim.detected and sim.found and sim.isolated
    negative = {str(o) for o in sim.observations if not o.positive}
    assert negative == {
        "not_running(hector_mapping)",
        "not_ok(hector_mapping,cpu)",
        "not_ok(hector_mapping,mem)",
    }


def test_full_adder_examples_3_22_and_3_23() -> None:
    adder = load_theory(str(ADDER))
    assert adder.components == ("a1", "a2", "o1", "x1", "x2")
    theta = parse_observations(ADDER_OBS.read_text(), str(ADDER_OBS), adder)
    result = diagnose(adder, theta)
    assert result.conflicts == (("x1", "x2"), ("a2", "o1", "x1"))
    assert result.diagnoses == (("x1",), ("a2", "x2"), ("o1", "x2"))


def test_full_adder_bounded_search_says_so() -> None:
    adder = load_theory(str(ADDER))
    theta = parse_observations(ADDER_OBS.read_text(), str(ADDER_OBS), adder)
    result = diagnose(adder, theta, max_card=1)
    assert result.bounded and result.diagnoses == (("x1",),)
    assert not diagnose(adder, theta, max_card=2).bounded


def test_fault_mode_rule_rules_a_candidate_out() -> None:
    clauses = tuple(parse_clause(r) for r in ("NAB(a), NAB(b) -> ok(x)", "AB(a) -> not_ok(y)"))
    theory = Theory(clauses, (Atom("ok", ("x",)), Atom("ok", ("y",))), components_of(clauses))
    result = diagnose(theory, lits(theory, "not ok(x)", "ok(y)"))
    assert result.conflicts == (("a", "b"),)  # Definition 3.33: NAB only
    assert result.diagnoses == (("b",),)  # AB(a) would predict not_ok(y)


def test_section_6_3_fault_mode_file() -> None:
    text = (ROOT / "tests" / "diagnosis" / "imu_fault_mode.yaml").read_text()
    theory = parse_model_yaml(text, "imu_fault_mode.yaml")
    blamed = diagnose(theory, lits(theory, "not ok(imu_data)", "running(imu_node)"))
    assert blamed.diagnoses == (("imu_node",),)
    # imu_node down, yet its data fine: the fault mode contradicts, no diagnosis exists
    impossible = diagnose(theory, lits(theory, "ok(imu_data)", "not running(imu_node)"))
    assert not impossible.consistent and impossible.diagnoses == ()
    assert impossible.conflicts == (("imu_node",),)


def test_observations_contradicting_the_model_alone() -> None:
    clauses = (parse_clause("ok(x) -> false"), parse_clause("NAB(a) -> ok(y)"))
    theory = Theory(clauses, (Atom("ok", ("x",)),), components_of(clauses))
    result = diagnose(theory, lits(theory, "ok(x)"))
    assert not result.consistent and result.diagnoses == () and result.conflicts == ((),)


def test_collect_later_literal_wins(tedusar: Theory) -> None:
    theta = lits(tedusar, "running(rviz)", "ok(pose)", "not running(rviz)")
    assert [str(t) for t in theta] == ["ok(pose)", "not_running(rviz)"]


@pytest.mark.parametrize(
    "text", ["ok(pose)", "not ok(pose)", "not_ok(pose)", "¬ok(pose)", " ¬ ok(pose) "]
)
def test_literal_spellings(tedusar: Theory, text: str) -> None:
    literal = parse_literal(text, tedusar)
    assert literal.atom == Atom("ok", ("pose",))
    assert literal.positive == (text == "ok(pose)")
    assert str(literal) == ("ok(pose)" if literal.positive else "not_ok(pose)")


def test_unknown_atom_has_did_you_mean(tedusar: Theory) -> None:
    with pytest.raises(RacError) as err:
        parse_literal("ok(poze)", tedusar)
    (diag,) = err.value.diagnostics
    assert diag.code == "RAC040" and diag.hint == "did you mean 'ok(pose)'?"


@pytest.mark.parametrize("text", ["ok(pose", "ok(a b)", "", "not", "NAB(jaguar)"])
def test_bad_literals(tedusar: Theory, text: str) -> None:
    with pytest.raises(RacError) as err:
        parse_literal(text, tedusar)
    assert err.value.diagnostics[0].code in {"RAC040", "RAC041"}


def test_observation_file_errors_name_line_and_column(tedusar: Theory) -> None:
    text = "# header\nok(pose)\n   ok(poze)  # typo\nok((\n"
    with pytest.raises(RacError) as err:
        parse_observations(text, "obs.txt", tedusar)
    spans = [(d.code, d.span.line, d.span.column) for d in err.value.diagnostics if d.span]
    assert spans == [("RAC040", 3, 4), ("RAC041", 4, 1)]


def test_model_yaml_errors_have_lines() -> None:
    text = (
        "ab: AB\nrulez: []\nrules:\n  - NAB(a) -> ok(x)\n  - NAB(a) ok(y)\n  - AB(a, b) -> ok(z)\n"
    )
    with pytest.raises(RacError) as err:
        parse_model_yaml(text, "m.yaml")
    found = [(d.code, d.span.line if d.span else None) for d in err.value.diagnostics]
    assert found == [("RAC006", 2), ("RAC006", 5), ("RAC006", 6)]
    assert err.value.diagnostics[0].hint == "did you mean 'rules'?"


def test_model_yaml_errors_come_in_file_order() -> None:
    """The rules are read first, whatever their place: their errors came after the props'
    and the keys' ones, though above them in the file."""
    text = 'props:\n  - "ok("\nrules:\n  - "a -> b("\n  - "x, -> y"\nbogus: 1\n'
    with pytest.raises(RacError) as err:
        parse_model_yaml(text, "m.yaml")
    lines = [d.span.line for d in err.value.diagnostics if d.span]
    assert lines == [2, 4, 5, 6]
    text = 'rules:\n  - "a -> b("\nprops:\n  - "ok("\nbogus: 1\n'
    with pytest.raises(RacError) as err:
        parse_model_yaml(text, "m.yaml")
    assert [d.span.line for d in err.value.diagnostics if d.span] == [2, 4, 5]


@pytest.mark.parametrize("text", ["[1, 2]", "rules: 3\n", "rules: [\n", "props: []\n"])
def test_model_yaml_shape_errors(text: str) -> None:
    with pytest.raises(RacError) as err:
        parse_model_yaml(text, "m.yaml")
    assert {d.code for d in err.value.diagnostics} == {"RAC006"}


def test_generated_model_yaml_gives_the_same_theory(tedusar: Theory, tmp_path: Path) -> None:
    from rac.pipeline import compile_model
    from rac.targets import EmitOptions
    from rac.targets.model_yaml import emit_model_yaml

    assert tedusar.model is not None
    text = emit_model_yaml(compile_model(tedusar.model), EmitOptions())
    theory = parse_model_yaml(text, "model.yaml")
    assert set(theory.clauses) == set(tedusar.clauses)
    assert theory.components == tedusar.components and theory.model is None


def test_all_single_faults_on_tedusar(tedusar: Theory) -> None:
    sims = all_single_faults(tedusar)
    assert [s.faults for s in sims] == [(c,) for c in tedusar.components]
    assert all(s.detected and s.found for s in sims)
    # each node has a running() observer and each switchable device an on() observer, so
    # every single fault has a symptom no other component explains
    assert all(s.isolated for s in sims)
    assert ambiguity_groups(sims) == ()


def test_ambiguity_groups_name_indistinguishable_components() -> None:
    clauses = tuple(
        parse_clause(r) for r in ("NAB(a), NAB(b) -> ok(x)", "NAB(c) -> ok(y)", "NAB(d) -> on(d)")
    )
    theory = Theory(clauses, (Atom("ok", ("x",)), Atom("ok", ("y",))), components_of(clauses))
    sims = all_single_faults(theory)
    by_comp = {s.faults[0]: s for s in sims}
    assert not by_comp["a"].isolated and by_comp["a"].found
    assert by_comp["c"].isolated
    assert not by_comp["d"].detected  # nobody observes on(d)
    assert ambiguity_groups(sims) == (("a", "b"),)


def test_predict_is_the_all_normal_model_without_faults(tedusar: Theory) -> None:
    assert all(o.positive for o in predict(tedusar, []))
    double = simulate(tedusar, ["jaguar", "imu_node"])
    assert double.found and ("imu_node", "jaguar") in double.result.diagnoses


def test_unknown_component_in_fault(tedusar: Theory) -> None:
    with pytest.raises(RacError) as err:
        simulate(tedusar, ["jaguar_nod"])
    assert err.value.diagnostics[0].code == "RAC042"
    assert err.value.diagnostics[0].hint == "did you mean 'jaguar_node'?"


@pytest.fixture
def known_atoms_calls(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """One entry per call of known_atoms (a pass over the whole model) from now on."""
    import rac.diagnosis.theory as theory_module

    calls: list[int] = []
    real = theory_module.known_atoms

    def counting(theory: Theory) -> frozenset[Atom]:
        calls.append(1)
        return real(theory)

    monkeypatch.setattr(theory_module, "known_atoms", counting)
    return calls


def test_observation_file_scans_the_model_once(
    tedusar: Theory, known_atoms_calls: list[int]
) -> None:
    """known_atoms is a pass over the whole model: once per file, not once per line.

    Once per line made a 3,000-line file on a 1,000-component model take 30 s.
    """
    calls = known_atoms_calls
    text = "\n".join(str(a) for a in tedusar.props)
    assert len(parse_observations(text, "obs.txt", tedusar)) == len(tedusar.props)
    assert len(calls) <= 1  # none at all: the clause index answers (KnownAtoms)


def test_parse_literal_does_not_scan_the_model_per_call(
    tedusar: Theory, known_atoms_calls: list[int]
) -> None:
    """parse_literal once per observation built known_atoms (a set of every atom of the
    model) each time: quadratic in the observations; now once per theory."""
    calls = known_atoms_calls
    literals = [parse_literal(f"not {a}", tedusar) for a in tedusar.props]
    assert [lit.atom for lit in literals] == list(tedusar.props)
    assert not any(lit.positive for lit in literals)
    assert len(calls) <= 1
    with pytest.raises(RacError) as err:  # an unknown atom still names the nearest one
        parse_literal("ok(poze)", tedusar)
    assert err.value.diagnostics[0].hint == "did you mean 'ok(pose)'?"


@pytest.mark.parametrize("text", ["", "# only a comment\n"])
def test_empty_model_yaml_names_the_file(text: str) -> None:
    with pytest.raises(RacError) as err:
        parse_model_yaml(text, "m.yaml")
    (diag,) = err.value.diagnostics
    assert diag.code == "RAC006" and diag.span is not None and diag.span.file == "m.yaml"
