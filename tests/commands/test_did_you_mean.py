"""Every name a user types gets a did-you-mean, in every command (issue 38): nodes, topics,
hardware, machines, atoms, fault kinds and targets, observer kinds in a costs file, launch
arguments, and the choices of the command line itself.  The test walks the commands with a
misspelt name each and checks that the hint names what was meant."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"

SPREAD = """robot spread
machine base address 10.0.0.2
machine arm address 10.0.0.3
topic /scan @ 10 Hz
node laser on base { publishes /scan }
node planner on arm { subscribes /scan }
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("names")
    build = tmp / "build"
    assert main(["compile", str(TEDUSAR), "-o", str(build), "-q"]) == 0
    spread = tmp / "spread.ram"
    spread.write_text(SPREAD, encoding="utf-8")
    spread_build = tmp / "spread"
    assert main(["compile", str(spread), "-o", str(spread_build), "-q"]) == 0
    run = tmp / "run.bag"
    assert main(["synth", str(TEDUSAR), "-o", str(run), "--duration", "3", "-q"]) == 0
    truth = tmp / "typo.faults.yaml"
    truth.write_text(
        "faults:\n- kind: crash\n  target: joy_nod\n  start: 1.0\n  culprits: [joy_nod]\n",
        encoding="utf-8",
    )
    obs = tmp / "seen.obs"
    obs.write_text("not ok(scna)\n", encoding="utf-8")
    costs = tmp / "costs.yaml"
    costs.write_text("GObs /mapp: 5\n", encoding="utf-8")
    return {
        "ram": TEDUSAR,
        "build": build,
        "model_yaml": build / "model.yaml",
        "spread": spread_build,
        "run": run,
        "truth": truth,
        "obs": obs,
        "costs": costs,
        "out": tmp / "never",
    }


# (command line, what the hint must name, exit code)
TYPOS = [
    ("diagnose {ram} --obs 'not ok(pse)'", "ok(pose)", 1),
    ("diagnose {model_yaml} --obs 'running(jaguar_nod)'", "running(jaguar_node)", 1),
    ("diagnose {ram} --obs-file {obs}", "ok(scan)", 1),
    ("repair {ram} --obs 'not ok(pse)'", "ok(pose)", 1),
    ("simulate {ram} --fault jaguar_nod", "jaguar_node", 1),
    ("scenario {ram} device-shutdown --device hokuy", "hokuyo", 1),
    ("scenario {ram} power-upp", "power-up", 2),
    ("analyze {ram} --mode crsh", "crash", 2),
    ("diagram {ram} -o {out}.svg --focus jaguar_nod", "jaguar_node", 1),
    ("diagram {ram} -o {out}.svg --diagnosis jaguar_nod", "jaguar_node", 1),
    ("diagram {ram} -o {out}.svg --diagnosis hokuyo,jaguarr", "hokuyo,jaguar", 1),
    ("synth {ram} -o {out}.bag --fault crash@3:jaguar_nod", "jaguar_node", 1),
    ("synth {ram} -o {out}.bag --fault freq@3:/scna", "/scan", 1),
    ("synth {ram} -o {out}.bag --fault trip@3:jaguarr", "jaguar", 1),
    ("synth {ram} -o {out}.bag --fault crsh@3:jaguar_node", "crash", 2),
    ("demo {ram} --write-only -o {out} --fault crash@3:jaguar_nod", "jaguar_node", 1),
    ("demo {ram} --write-only -o {out} --fault trip@+3:jaguarr", "jaguar", 1),
    ("demo {ram} --write-only -o {out} --fault crsh@3:jaguar_node", "crash", 1),
    ("board switch jaguarr on --board 127.0.0.1:1 --model {ram}", "jaguar", 1),
    ("board control statu --control 127.0.0.1:1", "status", 1),
    ("replay {ram} {run} --truth {truth}", "joy_node", 1),
    ("evaluate --models {ram} --runs {run}", "joy_node", 1),
    ("place {ram} --costs {costs}", "GObs /map", 0),
    ("observe {spread}/observers.yaml --machine bse", "base", 1),
    ("repairer {spread}/model.yaml --machine bse", "base", 1),
    ("run {build} borad:=127.0.0.1:7000", "board", 1),
    ("watch --only diagnsis", "diagnosis", 2),
    ("compil {ram}", "compile", 2),
]


@pytest.mark.parametrize(("line", "meant", "exit_code"), TYPOS, ids=[t[0] for t in TYPOS])
def test_a_misspelt_name_gets_a_did_you_mean(
    line: str,
    meant: str,
    exit_code: int,
    files: dict[str, Path],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("ROS_VERSION", "1")
    if line.startswith("evaluate"):  # the run's own ground truth, misspelt
        files["run"].with_name("run.faults.yaml").write_text(
            files["truth"].read_text(encoding="utf-8"), encoding="utf-8"
        )
    argv = [arg.format(**files) for arg in shlex.split(line)]
    try:
        code = main(argv)
    except SystemExit as stop:  # argparse's own errors
        code = int(stop.code or 0)
    err = capsys.readouterr().err
    assert code == exit_code, err
    hints = [line for line in err.splitlines() if "did you mean" in line]
    assert hints and re.search(rf"[' ]{re.escape(meant)}[',?]", hints[0]), err
