"""No input makes racc crash: the regression corpus of issue 10, mutants and hypothesis.

A run ends in success or in a :class:`RacError` with a code (exit 1); anything else is a bug.
``bench/fuzz.py`` runs the same mutants by the hundred thousand, with a time-out per case.
"""

from __future__ import annotations

import json
import math
import random
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from fuzz_cases import (
    CORPUS,
    KINDS,
    make_case,
    mutate_text,
    remove_base_bags,
    run_case,
    seeds_ram,
    seeds_yaml,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rac.cli import main
from rac.diagnosis.theory import parse_literal
from rac.errors import RacError
from rac.interchange import parse_json
from rac.load.model_yaml import parse_model_yaml
from rac.logic import parse_atom
from rac.parse import parse_ram
from rac.pipeline import compile_model

_CODE = re.compile(r"RAC\d{3}")
_CASES = sorted(p for p in CORPUS.iterdir() if p.suffix in (".ram", ".json", ".yaml", ".obs"))


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(argv)
    return code, capsys.readouterr().err


@pytest.mark.parametrize("case", _CASES, ids=lambda p: p.name)
def test_corpus_reproducer_is_a_clean_error(
    case: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    expected = set(_CODE.findall(case.stem))
    if case.suffix == ".obs":
        model = tmp_path / "model.yaml"
        model.write_text(seeds_yaml()[0], encoding="utf-8")
        runs = [["diagnose", str(model), "--obs", case.read_text(encoding="utf-8")]]
    elif case.suffix == ".yaml":
        runs = [["diagnose", str(case), "--obs", "ok(a)"]]
    else:
        out = tmp_path / "out"
        runs = [["check", str(case)], ["compile", str(case), "-o", str(out)]]
    for argv in runs:
        code, err = _run(argv, capsys)
        assert code == 1, err[-2000:]
        assert set(_CODE.findall(err)) >= expected, err[-2000:]
        assert "internal error" not in err and "Traceback" not in err
        # Linear output: at most 50 errors, each one short.
        assert len(err) < 50_000, f"{len(err):,} characters of errors"
    assert not (tmp_path / "out").exists()


def test_corpus_reproducer_six_megabyte_model_yaml(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "big.yaml"
    path.write_text("rules:\n- '" + "NAB(a), " * 750_000 + "'\n", encoding="utf-8")
    code, err = _run(["diagnose", str(path), "--obs", "ok(a)"], capsys)
    assert code == 1 and "error[RAC006]" in err


def test_corpus_reproducer_one_megabyte_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "long.ram"
    path.write_text(f"robot r\ntopic /t {{ {'f' * 1_000_000} }}\n", encoding="utf-8")
    code, err = _run(["compile", str(path), "-o", str(tmp_path / "out")], capsys)
    assert code == 1 and "error[RAC008]" in err and len(err) < 5_000
    assert not (tmp_path / "out").exists()


def test_many_errors_are_capped(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "many.ram"
    names = ", ".join(f"/u{i}" for i in range(3000))
    path.write_text(f"robot r\nnode n {{ subscribes {names} }}\n", encoding="utf-8")
    code, err = _run(["check", str(path)], capsys)
    assert code == 1
    assert err.count("error[RAC012]") == 50
    assert err.rstrip().endswith("… and 2950 more")
    assert max(len(line) for line in err.splitlines()) < 700


def test_internal_error_exit_70_and_debug_traceback(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def boom(_path: str, **_: object) -> None:
        raise KeyError("simulated bug")

    monkeypatch.setattr("rac.commands.check.load_and_compile", boom)
    monkeypatch.delenv("RACC_DEBUG", raising=False)
    code, err = _run(["check", "x.ram"], capsys)
    assert code == 70
    assert err.startswith("racc: internal error (please report): KeyError: 'simulated bug'")
    assert "Traceback" not in err
    code, err = _run(["--debug", "check", "x.ram"], capsys)
    assert code == 70 and "Traceback" in err
    monkeypatch.setenv("RACC_DEBUG", "1")
    code, err = _run(["check", "x.ram"], capsys)
    assert code == 70 and "Traceback" in err


# Mutants, in-process and cheap: thousands in a few seconds.  Each must parse and validate, or
# fail with a RacError; the slower end-to-end check with outputs read back runs on fewer.


def _clean(call: object) -> None:
    try:
        call()  # type: ignore[operator]
    except RacError as err:
        assert err.diagnostics and all(_CODE.fullmatch(d.code) for d in err.diagnostics)
        err.render()


@pytest.mark.slow
@pytest.mark.parametrize("block", range(4))
def test_ram_mutants_never_crash(block: int) -> None:
    for seed in range(block * 500, block * 500 + 500):
        text = make_case("ram", seed).text
        _clean(lambda text=text: compile_model(parse_ram(text, "m.ram")))


@pytest.mark.slow
def test_json_mutants_never_crash() -> None:
    for seed in range(1500):
        text = make_case("json", seed).text
        _clean(lambda text=text: compile_model(parse_json(text, "m.json")))


def test_yaml_mutants_never_crash() -> None:
    for seed in range(600):
        text = make_case("yaml", seed).text
        _clean(lambda text=text: parse_model_yaml(text, "m.yaml"))


def test_literal_mutants_never_crash() -> None:
    theory = parse_model_yaml(seeds_yaml()[0], "model.yaml")
    for seed in range(3000):
        text = make_case("literal", seed).text
        _clean(lambda text=text: parse_literal(text, theory))


@pytest.fixture(scope="module", autouse=True)
def _base_recordings_removed() -> Iterator[None]:
    """The damaged-bag kinds' base recordings (made once) go when the module is done."""
    yield
    remove_base_bags()


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_end_to_end_mutants_outputs_read_back(kind: str, tmp_path: Path) -> None:
    """Through the CLI: every accepted model's outputs parse, model.yaml via racc diagnose."""
    for seed in range(40):
        workdir = tmp_path / str(seed)
        workdir.mkdir()
        outcome, detail = run_case(make_case(kind, seed), workdir)
        assert outcome in ("accepted", "error"), f"make_case({kind!r}, {seed}): {detail}"


# Hypothesis: arbitrary text where the mutants only edit valid text.

_SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@_SETTINGS
@given(st.text(max_size=200))
def test_any_text_as_ram(text: str) -> None:
    _clean(lambda: compile_model(parse_ram("robot r\n" + text, "m.ram")))


@_SETTINGS
@given(st.text(max_size=300))
def test_any_text_as_atom(text: str) -> None:
    try:
        atom = parse_atom(text)
    except ValueError:
        return
    assert parse_atom(str(atom)) == atom  # what it accepts, it writes back readably


_JSON = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=20,
)


@pytest.mark.slow
@_SETTINGS
@given(_JSON, st.data())
def test_any_json_values_in_a_model(value: object, data: st.DataObject) -> None:
    doc = json.loads(seeds_json_doc())
    rng = random.Random(data.draw(st.integers(0, 10**6)))
    topic = rng.choice(doc["topics"])
    topic[rng.choice(["name", "type", "fields", "rate_hz", "window_s"])] = value
    text = json.dumps(doc, allow_nan=True)
    _clean(lambda: compile_model(parse_json(text, "m.json")))


def seeds_json_doc() -> str:
    from fuzz_cases import seeds_json

    return seeds_json()[0]


def test_mutation_helper_is_deterministic() -> None:
    assert make_case("ram", 7) == make_case("ram", 7)
    text = seeds_ram()[0]
    assert mutate_text(text, random.Random(1)) == mutate_text(text, random.Random(1))
    assert math.isfinite(len(text))


@pytest.mark.parametrize("seed", [4743, 5469])
def test_sqlite3_rows_whose_data_is_not_a_blob(seed: int, tmp_path: Path) -> None:
    """bench/fuzz.py's two crashes in 10,000 damaged sqlite3 bags: a row whose data column
    reads NULL or text gave a TypeError (exit 70), now RAC080."""
    outcome, detail = run_case(make_case("sqlite3", seed), tmp_path)
    assert outcome == "error" and "error[RAC080]" in detail and "is not bytes" in detail, detail
