"""The fast paths of issue 14 read and decide exactly what the general ones do.

model.yaml's line reader against libyaml's parser, the one-match observation lines against
the general literal parser, batched ``--obs`` runs against argparse, the singleton conflicts
read off the all-normal closure against the plain search.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rac.load.model_yaml as model_yaml
from rac.cli import main
from rac.commands.common import batched_runs, run_values
from rac.diagnosis import Theory, diagnose, predict
from rac.diagnosis.search import minimal_sets, transversals
from rac.diagnosis.theory import literal_at
from rac.errors import RacError
from rac.load.observations import parse_observations
from rac.load.theory import load_theory
from rac.pipeline import compile_model
from rac.targets import EmitOptions
from rac.targets.model_yaml import emit_model_yaml

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"


@pytest.fixture(scope="module")
def generated() -> str:
    from rac.load.files import load_model

    return emit_model_yaml(compile_model(load_model(TEDUSAR)), EmitOptions())


def _slow(text: str, file: str = "m.yaml") -> Theory:
    """The theory through libyaml's parser only."""
    fast = model_yaml._fast_entries
    model_yaml._fast_entries = lambda text, file: None
    try:
        return model_yaml.parse_model_yaml(text, file)
    finally:
        model_yaml._fast_entries = fast


def test_generated_model_yaml_takes_the_line_reader(generated: str) -> None:
    assert model_yaml._fast_entries(generated, "m.yaml") is not None
    assert model_yaml.parse_model_yaml(generated, "m.yaml") == _slow(generated)


def _read_both(text: str) -> tuple[Theory | str, Theory | str]:
    """The theory (or the rendered errors) from the general reader and from the fast one."""
    try:
        expected: Theory | str = _slow(text)
    except RacError as err:
        expected = err.render()
    try:
        got: Theory | str = model_yaml.parse_model_yaml(text, "m.yaml")
    except RacError as err:
        got = err.render()
    return expected, got


@pytest.mark.parametrize(
    "edit",
    [
        lambda t: t.replace("rules:\n", "rules:\n  # a comment, indented\n", 1),
        lambda t: t.replace("\n- ", "\n  - "),  # indented lists
        lambda t: t.replace(" -> ", "\n  -> ", 1),  # a rule over two lines
        lambda t: t.replace("ab: AB", "ab: 'AB'"),
        lambda t: t.replace("rules:\n- ", 'rules:\n- "', 1).replace("\n", '"\n', 0),
        lambda t: t.replace("\n- NAB(", "\n-   NAB(", 3),
        lambda t: t.replace(", ", " , ", 5).replace(",", ", ", 7),
        lambda t: t + "\n\n# trailing comment\n",
        lambda t: "---\n" + t,
    ],
)
def test_every_layout_reads_as_libyaml_reads_it(generated: str, edit: object) -> None:
    text = edit(generated)  # type: ignore[operator]
    expected, got = _read_both(text)
    assert got == expected


@pytest.mark.parametrize(
    "text",
    [
        "rules:\n- NAB(a) -> ok(x)\n- NAB(a) ok(y)\n- AB(a,b) -> ok(z)\n- not_AB(a) -> ok(w)\n",
        "rules:\n- -> false\n- NAB(a), , ok(b) -> ok(c)\n",
        "props:\n- ok(x\nrules:\n- NAB(a) -> ok(x)\nrulez:\n",
        "ab: AB\nnab: AB\nrules:\n- AB(x) -> ok(x)\n",
    ],
)
def test_line_reader_errors_are_located_as_libyaml_locates_them(text: str) -> None:
    with pytest.raises(RacError) as fast:
        model_yaml.parse_model_yaml(text, "m.yaml")
    with pytest.raises(RacError) as slow:
        _slow(text)
    assert fast.value.render() == slow.value.render()
    assert all(d.span is not None for d in fast.value.diagnostics)


def test_observation_lines_read_as_single_literals(tmp_path: Path) -> None:
    theory = load_theory(str(TEDUSAR))
    lines = [
        "ok(pose)",
        "  not   ok(scan)  ",
        "not_ok(imu_data)",
        "running(rviz) # comment",
        "¬ on(jaguar)",
    ]
    read = parse_observations("\n".join(lines), "obs.txt", theory)
    one_by_one = tuple(literal_at(line.split("#")[0].strip(), theory, None) for line in lines)
    assert read == one_by_one
    with pytest.raises(RacError) as err:
        parse_observations("ok(pose)\nok(nothing)\nNAB(rviz)\n", "obs.txt", theory)
    assert [(d.code, d.span.line) for d in err.value.diagnostics if d.span] == [
        ("RAC040", 2),
        ("RAC040", 3),
    ]


def test_batched_runs_keep_order_and_leave_the_rest() -> None:
    batched = {"--obs": "--obs-run"}
    args = [
        "m",
        "--obs",
        "a",
        "--obs=b",
        "--obs-file",
        "f",
        "--obs",
        "c",
        "--obs",
        "-x",
        "--",
        "--obs",
        "d",
    ]
    out = batched_runs(args, batched)
    assert out == [
        "m",
        "--obs-run",
        "a\0b",
        "--obs-file",
        "f",
        "--obs",
        "c",
        "--obs",
        "-x",
        "--",
        "--obs",
        "d",
    ]
    assert run_values(out[2]) == ["a", "b"]
    assert batched_runs(["--obs", "a"], batched) == ["--obs", "a"]


def test_thousands_of_obs_in_command_line_order(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """Later literals win across --obs runs and --obs-file, as with a few options."""
    theory = load_theory(str(TEDUSAR))
    literals = [str(o) for o in predict(theory, ["hokuyo"])]
    obs_file = tmp_path / "obs.txt"
    obs_file.write_text("ok(scan)\n")  # overridden by the --obs after it
    argv = ["diagnose", str(TEDUSAR)]
    for _ in range(200):
        argv += [x for lit in literals for x in ("--obs", lit.replace("not_", "not "))]
    argv += ["--obs-file", str(obs_file)]
    argv += [x for lit in literals for x in ("--obs", lit.replace("not_", "not "))]
    assert main([*argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["diagnoses"] == [{"bad": ["hokuyo"]}]


def test_everything_down_is_one_diagnosis_of_every_component() -> None:
    theory = load_theory(str(TEDUSAR))
    every = list(theory.components)
    result = diagnose(theory, predict(theory, every))
    assert result.diagnoses == (tuple(every),)
    assert result.conflicts == tuple((c,) for c in every)


def test_minimal_sets_and_transversals_with_singletons() -> None:
    sets = [frozenset("ab"), frozenset("a"), frozenset("bc"), frozenset("c"), frozenset("d")]
    assert minimal_sets(sets) == [frozenset("a"), frozenset("c"), frozenset("d")]
    assert minimal_sets([frozenset("ab"), frozenset()]) == [frozenset()]
    assert transversals([frozenset("abc")]) == [frozenset("a"), frozenset("b"), frozenset("c")]
    assert transversals([frozenset("ab"), frozenset("bc")]) == [frozenset("b"), frozenset("ac")]


def _index_arrays(theory: Theory) -> tuple[object, ...]:
    from rac.diagnosis.engine import Index

    index = Index(theory)
    return (
        index.keys,
        [list(b) for b in index.body],
        list(index.head),
        index.complement,
        index.mentioned,
        [index.literal_id(p, a, v) for p, a in index.keys for v in (True, False)],
        index.facts,
        index.monotone,
        dict(index.ids),
        index.component,
        [index.is_ab(a) for a in index.component],
    )


TABLE_EDITS = [
    lambda t: t,
    lambda t: t.replace("rules:\n", "rules:\n- NAB(extra), NAB(extra), ok(x) -> ok(y)\n", 1),
    lambda t: t.replace("rules:\n", "rules:\n- -> ok(fact)\n- ok(fact) -> false\n", 1),
    lambda t: t + t[t.index("rules:\n") + 7 :],  # every rule twice
    lambda t: t.replace("props:\n", "props:\n- only_a_prop(x)\n- only_a_prop(x)\n", 1),
    lambda t: t.replace(" -> ", "  ->  ", 3),  # another layout: no table, same theory
]


@pytest.mark.parametrize("edit", TABLE_EDITS)
def test_the_clause_table_numbers_atoms_as_the_index_does(generated: str, edit: object) -> None:
    import dataclasses

    text = edit(generated)  # type: ignore[operator]
    theory = model_yaml.parse_model_yaml(text, "m.yaml")
    assert theory == _slow(text)
    plain = dataclasses.replace(theory, table=None)
    assert _index_arrays(theory) == _index_arrays(plain)
    if "  ->  " not in text:
        assert theory.table is not None and theory.table.clauses is theory.clauses


def test_a_stale_clause_table_is_ignored(generated: str) -> None:
    import dataclasses

    theory = model_yaml.parse_model_yaml(generated, "m.yaml")
    fewer = dataclasses.replace(theory, clauses=theory.clauses[1:])  # the table stays behind
    assert _index_arrays(fewer) == _index_arrays(dataclasses.replace(fewer, table=None))


_ATOMS = ["NAB(a)", "NAB(b)", "AB(a)", "ok(x)", "not_ok(x)", "ok(y)", "p", "q(a,b)", "false"]


@st.composite
def _model_texts(draw: st.DrawFn) -> str:
    """model.yaml texts near racc's layout: blocks interrupted by comments, blanks, odd spacing."""
    indent = draw(st.sampled_from(["", "  "]))
    lines = ["ab: AB", "props:"]
    lines += [f"{indent}- {a}" for a in draw(st.lists(st.sampled_from(_ATOMS), max_size=3))]
    lines.append("rules:")
    for _ in range(draw(st.integers(0, 12))):
        body = draw(st.lists(st.sampled_from(_ATOMS), max_size=3))
        head = draw(st.sampled_from(_ATOMS))
        sep = draw(st.sampled_from([", ", ",", " , "]))
        arrow = draw(st.sampled_from([" -> ", "->", " ->  "]))
        rule = f"{sep.join(body)}{arrow}{head}" if body else f"-> {head}"
        lines.append(f"{indent}- {rule}")
        lines += draw(st.sampled_from([[], [""], ["# note"], [f"{indent}  # note"]]))
    end = draw(st.sampled_from(["\n", "", "\n\n"]))
    return "\n".join(lines) + end


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(_model_texts())
def test_generated_layouts_read_and_number_as_the_general_path(text: str) -> None:
    import dataclasses

    expected, got = _read_both(text)
    assert got == expected
    if isinstance(got, Theory):
        assert _index_arrays(got) == _index_arrays(dataclasses.replace(got, table=None))
