"""``racc diagnose`` and ``racc simulate`` on the command line: output, JSON shape, exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rac.cli import main
from rac.logic import Atom

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
ADDER = str(ROOT / "tests" / "diagnosis" / "full_adder.yaml")
ADDER_OBS = str(ROOT / "tests" / "diagnosis" / "full_adder.obs")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_diagnose_json_is_exactly_the_contract(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(
        capsys,
        "diagnose",
        TEDUSAR,
        "--obs",
        "on(jaguar)",
        "--obs",
        "running(jaguar_node)",
        "--obs",
        "not ok(pose)",
        "--json",
    )
    assert code == 0
    doc = json.loads(out)
    assert list(doc) == ["consistent", "conflicts", "diagnoses"]
    assert doc["consistent"] is False
    assert doc["conflicts"] == [["jaguar", "jaguar_node"]]
    assert [d["bad"] for d in doc["diagnoses"]] == [["jaguar"], ["jaguar_node"]]
    assert all(list(d) == ["bad"] for d in doc["diagnoses"])  # good ones: --with-good


def test_diagnose_json_with_good_lists_every_other_component(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["--obs", "on(jaguar)", "--obs", "running(jaguar_node)", "--obs", "not ok(pose)"]
    code, out, _ = run(capsys, "diagnose", TEDUSAR, *argv, "--json", "--with-good")
    assert code == 0
    doc = json.loads(out)
    assert [d["bad"] for d in doc["diagnoses"]] == [["jaguar"], ["jaguar_node"]]
    for d in doc["diagnoses"]:
        assert list(d) == ["bad", "good"]
        assert not set(d["bad"]) & set(d["good"])
        assert d["good"] == sorted(d["good"])
        assert len(d["bad"]) + len(d["good"]) == 12


def test_diagnose_consistent_gives_one_empty_diagnosis(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "diagnose", TEDUSAR, "--obs", "ok(pose)", "--json")
    doc = json.loads(out)
    assert code == 0 and doc["consistent"] is True and doc["conflicts"] == []
    assert doc["diagnoses"] == [{"bad": []}]


def test_diagnose_table_on_the_full_adder(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "diagnose", ADDER, "--obs-file", ADDER_OBS)
    assert code == 0 and err == ""
    assert "consistent: no" in out
    assert "{x1, x2}" in out and "{a2, o1, x1}" in out
    assert "minimal diagnoses (3)" in out


def test_later_literals_win_across_obs_and_obs_file(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    obs = tmp_path / "obs.txt"
    obs.write_text("not running(rviz)  # stopped\n")
    code, out, _ = run(
        capsys, "diagnose", TEDUSAR, "--obs-file", str(obs), "--obs", "running(rviz)", "--json"
    )
    assert code == 0 and json.loads(out)["consistent"] is True
    code, out, _ = run(
        capsys, "diagnose", TEDUSAR, "--obs", "running(rviz)", "--obs-file", str(obs), "--json"
    )
    assert json.loads(out)["diagnoses"][0]["bad"] == ["rviz"]


def test_bounded_search_is_noted_on_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(
        capsys, "diagnose", ADDER, "--obs-file", ADDER_OBS, "--max-card", "1", "--json"
    )
    assert code == 0 and "bounded" in err
    assert list(json.loads(out)) == ["consistent", "conflicts", "diagnoses"]


def test_bad_observation_file_names_file_line_column(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    obs = tmp_path / "obs.txt"
    obs.write_text("ok(pose)\n  running(rvis)\n")
    code, _, err = run(capsys, "diagnose", TEDUSAR, "--obs-file", str(obs))
    assert code == 1
    assert f"{obs}:2:3: error[RAC040]" in err and "running(rviz)" in err


@pytest.mark.parametrize(
    ("argv", "code", "needle"),
    [
        (["diagnose", TEDUSAR, "--obs", "ok(poze)"], 1, "RAC040"),
        (["diagnose", TEDUSAR, "--obs", "ok(pose"], 1, "RAC041"),
        (["diagnose", "missing.ram", "--obs", "ok(pose)"], 1, "RAC004"),
        (["diagnose", TEDUSAR, "--obs-file", "missing.txt"], 1, "RAC004"),
        (["diagnose", TEDUSAR, "--max-card", "-1"], 2, "must be 0 or more"),
        (["diagnose", TEDUSAR, "--max-card", "x"], 2, "not a number"),
        (["simulate", TEDUSAR], 2, "required"),
        (["simulate", TEDUSAR, "--fault", "a", "--all-single-faults"], 2, "not allowed"),
        (["simulate", TEDUSAR, "--fault", "jaguar_nod"], 1, "did you mean 'jaguar_node'?"),
    ],
)
def test_exit_codes(
    capsys: pytest.CaptureFixture[str], argv: list[str], code: int, needle: str
) -> None:
    try:
        got = main(argv)
    except SystemExit as exc:  # argparse
        got = int(exc.code or 0)
    assert got == code
    assert needle in capsys.readouterr().err


def test_diagnose_reads_model_yaml_written_by_compile(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    assert main(["compile", TEDUSAR, "-o", str(tmp_path), "--no-svg", "-q"]) == 0
    capsys.readouterr()
    args = ["--obs", "not running(imu_node)", "--json"]
    _, from_yaml, _ = run(capsys, "diagnose", str(tmp_path / "model.yaml"), *args)
    _, from_ram, _ = run(capsys, "diagnose", TEDUSAR, *args)
    assert json.loads(from_yaml) == json.loads(from_ram)
    assert json.loads(from_ram)["diagnoses"][0]["bad"] == ["imu_node"]


def test_simulate_single_fault_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "simulate", TEDUSAR, "--fault", "jaguar", "--json")
    doc = json.loads(out)
    assert code == 0 and doc["faults"] == ["jaguar"]
    assert doc["detected"] and doc["found"] and doc["isolated"]
    assert "not_on(jaguar)" in doc["observations"] and "not_ok(pose)" in doc["observations"]
    assert [d["bad"] for d in doc["diagnoses"]] == [["jaguar"]]


def test_simulate_all_single_faults_table(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "simulate", TEDUSAR, "--all-single-faults")
    assert code == 0
    rows = [line.split() for line in out.splitlines()[1:13]]
    assert len(rows) == 12 and all(r[1] == "yes" for r in rows)
    assert "12/12 faults detected" in out and "ambiguity groups" in out


def test_simulate_all_single_faults_names_groups(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    model = tmp_path / "m.yaml"
    model.write_text("props: [ok(x)]\nrules:\n  - NAB(a), NAB(b) -> ok(x)\n")
    code, out, _ = run(capsys, "simulate", str(model), "--all-single-faults", "--json")
    doc = json.loads(out)
    assert code == 0 and doc["ambiguity_groups"] == [["a", "b"]]
    assert [c["candidates"] for c in doc["components"]] == [2, 2]
    code, out, _ = run(capsys, "simulate", str(model), "--all-single-faults")
    assert "{a, b}" in out


def test_max_card_0_does_not_claim_that_no_diagnosis_exists(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = run(
        capsys, "diagnose", TEDUSAR, "--obs", "not ok(pose)", "--max-card", "0", "--json"
    )
    assert code == 0 and json.loads(out)["diagnoses"] == []
    assert "bounded at 0" in err and "no diagnosis exists" not in err


def test_all_single_faults_table_names_undetected_faults(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    model = tmp_path / "m.yaml"
    model.write_text("props: [ok(x)]\nrules:\n  - NAB(a) -> ok(x)\n  - NAB(d) -> on(d)\n")
    code, out, _ = run(capsys, "simulate", str(model), "--all-single-faults")
    assert code == 0 and "1/2 faults detected" in out
    assert "every single fault is told apart" not in out
    assert "undetected (no observer sees a symptom; add observers): d" in out


def test_many_obs_scan_the_model_once(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import rac.diagnosis.theory as theory_module

    calls: list[int] = []
    real = theory_module.known_atoms

    def counting(theory: theory_module.Theory) -> frozenset[Atom]:
        calls.append(1)
        return real(theory)

    monkeypatch.setattr(theory_module, "known_atoms", counting)
    argv = ["--obs", "ok(pose)", "--obs", "running(rviz)", "--obs", "not ok(scan)"]
    code, _, _ = run(capsys, "diagnose", TEDUSAR, *argv)
    assert code == 0 and len(calls) <= 1  # none at all: the clause index answers


def test_all_single_faults_table_says_when_bounded(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "simulate", TEDUSAR, "--all-single-faults", "--max-card", "0")
    assert code == 0 and "0/12 isolated" in out and "bounded by --max-card" in out
