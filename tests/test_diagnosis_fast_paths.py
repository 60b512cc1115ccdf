"""The fast paths of issue 14 read and decide exactly what the general ones do.

model.yaml's line reader against libyaml's parser, the one-match observation lines against
the general literal parser, batched ``--obs`` runs against argparse, the singleton conflicts
read off the all-normal closure against the plain search.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import rac.diagnosis.model_yaml as model_yaml
from rac.cli import main
from rac.commands.common import batched_runs, run_values
from rac.diagnosis import Theory, diagnose, load_theory, predict
from rac.diagnosis.search import minimal_sets, transversals
from rac.diagnosis.theory import literal_at, parse_observations
from rac.errors import RacError
from rac.pipeline import compile_model
from rac.targets import EmitOptions
from rac.targets.model_yaml import emit_model_yaml

ROOT = Path(__file__).resolve().parent.parent
TEDUSAR = ROOT / "models" / "tedusar.ram"


@pytest.fixture(scope="module")
def generated() -> str:
    from rac.loader import load_model

    return emit_model_yaml(compile_model(load_model(TEDUSAR)), EmitOptions())


def _slow(text: str, file: str = "m.yaml") -> Theory:
    """The theory through libyaml's parser only."""
    fast = model_yaml._fast_entries
    model_yaml._fast_entries = lambda text, file: None  # type: ignore[assignment]
    try:
        return model_yaml.parse_model_yaml(text, file)
    finally:
        model_yaml._fast_entries = fast


def test_generated_model_yaml_takes_the_line_reader(generated: str) -> None:
    assert model_yaml._fast_entries(generated, "m.yaml") is not None
    assert model_yaml.parse_model_yaml(generated, "m.yaml") == _slow(generated)


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
    try:
        expected: Theory | str = _slow(text)
    except RacError as err:
        expected = err.render()
    try:
        got: Theory | str = model_yaml.parse_model_yaml(text, "m.yaml")
    except RacError as err:
        got = err.render()
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
