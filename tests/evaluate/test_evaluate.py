"""racc evaluate: given models and the learning grid, scored against synthetic test runs
with the thesis's schedule (§10.2) — the shortened reproduction CI runs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import cast

import pytest

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
PIONEER = str(ROOT / "models" / "pioneer.ram")
DURATION = "300"


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """Two fault-free training runs, two thesis-schedule test runs, one fault-free test run."""
    d = tmp_path_factory.mktemp("pioneer")
    plan = {
        "train1": ["--seed", "1"],
        "train2": ["--seed", "2"],
        "test1": ["--seed", "3", "--schedule", "thesis"],
        "test2": ["--seed", "4", "--schedule", "thesis"],
        "clean": ["--seed", "5"],
    }
    out = {}
    for name, extra in plan.items():
        bag = str(d / f"{name}.bag")
        assert main(["synth", PIONEER, "-o", bag, "--duration", DURATION, "-q", *extra]) == 0
        out[name] = bag
    return out


def _evaluate(args: list[str], capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    assert main(["evaluate", *args, "--json"]) == 0
    doc: dict[str, object] = json.loads(capsys.readouterr().out)
    return doc


@pytest.mark.slow
def test_the_shortened_pioneer_reproduction(
    runs: dict[str, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["--learn-from", runs["train1"], runs["train2"], "--base", PIONEER]
    args += ["--runs", runs["test1"], runs["test2"], runs["clean"]]
    args += ["--save-models", str(tmp_path / "models")]
    doc = _evaluate(args, capsys)
    models = doc["models"]
    assert isinstance(models, list) and [m["label"] for m in models] == [
        f"M{i}" for i in range(1, 10)
    ]
    assert [(m["q"], m["alpha"]) for m in models][:2] == [(0.9, 10.0), (0.9, 2.5)]
    assert sorted(p.name for p in (tmp_path / "models").iterdir())[0] == "M1.ram"
    run_docs = cast("list[dict[str, list[object]]]", doc["runs"])  # docs/evaluate.md's JSON
    faults = sum(len(r["faults"]) for r in run_docs)
    assert faults == 12  # six per thesis run, none in the clean one

    def reported(m: dict[str, object]) -> int:
        outcomes = cast("list[dict[str, object]]", m["outcomes"])
        return sum(1 for o in outcomes if o["reported"])

    best = max(models, key=lambda m: (reported(m), -len(m["false_positives"])))
    assert reported(best) == 12 and best["false_positives"] == []
    for m in models:  # nothing diagnosed on a fault-free run not used for learning
        assert not [fp for fp in m["false_positives"] if fp["run"] == runs["clean"]], m


@pytest.mark.slow
def test_given_models_and_the_text_report(
    runs: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["evaluate", "--models", PIONEER, str(ROOT / "models" / "tedusar.ram")]
    # tedusar shares only /pose and /scan with the pioneer: its other observers stay silent
    # and its node observers see none of its nodes running, which it diagnoses.
    assert main([*args, "--runs", runs["test1"], "--markdown", "-q"]) == 0
    assert capsys.readouterr().out == ""
    assert main([*args, "--runs", runs["test1"], "--markdown"]) == 0
    text = capsys.readouterr().out
    assert "### Observers per model (Table 10.1)" in text
    assert "| pioneer | - | - | 3 | 3 | 7 | 7 | 7 | 2 |" in text
    assert "McNemar's exact test" in text
    # Table 10.2's count a perfect model scores is 'ideal', not 'target' (a fault's topic)
    assert "|  | fault | ideal | pioneer | tedusar |" in text


def test_evaluate_needs_ground_truth(
    short_pioneer_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = short_pioneer_run
    bag.with_name("r.faults.yaml").unlink()
    assert main(["evaluate", "--models", PIONEER, "--runs", str(bag)]) == 1
    assert "RAC052" in capsys.readouterr().err


def test_evaluate_checks_the_ground_truth_against_the_models(
    short_pioneer_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = short_pioneer_run
    truth = bag.with_name("r.faults.yaml")
    fault = "- {kind: crash, target: p2os, start: 5, end: 10, culprits: [p2os]}\n"
    truth.write_text("robot: pioneer\nduration: 20\nfaults:\n" + fault)
    tedusar = str(ROOT / "models" / "tedusar.ram")
    # a culprit in one of the models is what an evaluation compares; in none, a mistake
    assert main(["evaluate", "--models", PIONEER, tedusar, "--runs", str(bag), "-q"]) == 0
    assert main(["evaluate", "--models", tedusar, "--runs", str(bag), "-q"]) == 1
    err = capsys.readouterr().err
    assert "error[RAC086]: culprit 'p2os' of the crash fault is not in 'tedusar'" in err
    assert "warning[RAC107]" in err  # printed with the error, -q or not
