"""Every command given the wrong kind of path says what it was given, what it takes and what
to pass instead (issue 38): a directory for a model, a model for a recording, a recording
for a model, a model for the directory racc compile wrote.  The test walks every input of
every command that reads one, with each kind of path that input does not take."""

from __future__ import annotations

import os
import re
import shlex
from dataclasses import dataclass
from pathlib import Path

import pytest

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"


@dataclass(frozen=True)
class Paths:
    """One path of each kind a user may give by mistake."""

    ram: Path
    compiled: Path  # what racc compile wrote
    model_yaml: Path
    observers_yaml: Path
    ros1_bag: Path
    ros2_bag: Path  # a directory
    ros2_storage: Path  # the .db3 in it
    binary: Path
    empty_dir: Path
    out: Path  # a place for outputs never written


@pytest.fixture(scope="module")
def paths(tmp_path_factory: pytest.TempPathFactory) -> Paths:
    tmp = tmp_path_factory.mktemp("kinds")
    compiled = tmp / "build"
    assert main(["compile", str(TEDUSAR), "-o", str(compiled), "-q"]) == 0
    ros1 = tmp / "run.bag"
    assert main(["synth", str(TEDUSAR), "-o", str(ros1), "--duration", "2", "-q"]) == 0
    ros2 = tmp / "run2"
    assert main(["synth", str(TEDUSAR), "-o", str(ros2), "--ros2", "--duration", "2", "-q"]) == 0
    (storage,) = ros2.glob("*.db3")
    binary = tmp / "random.bag"
    binary.write_bytes(bytes(range(256)) * 8)
    empty = tmp / "empty"
    empty.mkdir()
    return Paths(
        ram=TEDUSAR,
        compiled=compiled,
        model_yaml=compiled / "model.yaml",
        observers_yaml=compiled / "observers.yaml",
        ros1_bag=ros1,
        ros2_bag=ros2,
        ros2_storage=storage,
        binary=binary,
        empty_dir=empty,
        out=tmp / "never",
    )


# The kinds each input takes is in rac/load/kinds.py; the wrong ones given here.
WRONG_FOR = {
    "model": ("compiled", "ros1_bag", "ros2_bag", "binary", "empty_dir"),
    "theory": ("compiled", "ros1_bag", "ros2_bag", "binary", "observers_yaml"),
    "recording": ("ram", "compiled", "binary", "model_yaml", "ros2_storage"),
    "compiled": ("ram", "ros1_bag", "model_yaml", "binary"),
    "robot_launch": ("ram", "compiled", "ros1_bag"),
    "observers": ("compiled", "ram", "model_yaml", "ros1_bag"),
    "tug": ("ram", "compiled", "ros1_bag"),
    "ram_file": ("compiled", "ros1_bag"),
    "file": ("compiled", "ros1_bag", "ram"),  # graph, properties, costs, observations
}

# Every input of every command that reads a path: the command line, with {x} where the path
# goes, and what the input takes.  {ram}, {bag}, {build}, {model_yaml} and {out} are right.
INPUTS = [
    ("compile {x} -o {out}", "model"),
    ("check {x}", "model"),
    ("export --json {x}", "model"),
    ("fmt --check {x}", "ram_file"),
    ("diagnose {x} --obs 'not ok(pose)'", "theory"),
    ("diagnose {ram} --obs-file {x}", "file"),
    ("repair {x} --obs 'not ok(pose)'", "theory"),
    ("scenario {x} power-up", "theory"),
    ("simulate {x} --all-single-faults", "theory"),
    ("analyze {x}", "theory"),
    ("diagram {x} -o {out}.svg", "model"),
    ("place {x}", "theory"),
    ("place {ram} --candidates {x}", "model"),
    ("place {ram} --costs {x}", "file"),
    ("synth {x} -o {out}.bag --duration 2", "model"),
    ("learn {x} -o {out}.ram", "recording"),
    ("learn {bag} -o {out}.ram --base {x}", "model"),
    ("learn {bag} -o {out}.ram --graph {x}", "file"),
    ("learn {bag} -o {out}.ram --properties {x}", "file"),
    ("replay {x} {bag}", "model"),
    ("replay {ram} {x}", "recording"),
    ("replay {ram} {bag} --properties {x}", "file"),
    ("evaluate --models {x} --runs {bag}", "model"),
    ("evaluate --models {ram} --runs {x}", "recording"),
    ("import tug {x} -o {out}.ram", "tug"),
    ("demo {x} --write-only -o {out}", "model"),
    ("board status --board 127.0.0.1:1 --model {x}", "model"),
    ("board-sim --model {x}", "model"),
    ("run {x}", "compiled"),
    ("run {build} --robot-launch {x}", "robot_launch"),
    ("observe {x}", "observers"),
    ("board-client {x} --board 127.0.0.1:1", "observers"),
    ("engine {x}", "theory"),
    ("repairer {x}", "theory"),
    ("repairer {model_yaml} --observers {x}", "observers"),
    ("repairer {model_yaml} --launch {x}", "robot_launch"),
]

CASES = [
    pytest.param(line, given, id=f"{line.split()[0]}:{line.split('{x}')[0].split()[-1]}:{given}")
    for line, takes in INPUTS
    for given in WRONG_FOR[takes]
]


@pytest.mark.parametrize(("line", "given"), CASES)
def test_a_wrong_kind_of_path_says_what_it_is_and_what_to_pass(
    line: str,
    given: str,
    paths: Paths,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("ROS_VERSION", "1")  # the live commands check their input first
    wrong = getattr(paths, given)
    right = {
        "x": wrong,
        "ram": paths.ram,
        "bag": paths.ros1_bag,
        "build": paths.compiled,
        "model_yaml": paths.model_yaml,
        "out": paths.out,
    }
    argv = [arg.format(**right) for arg in shlex.split(line)]
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 1, err
    said = [d for d in re.split(r"\n(?=\S)", err) if f"{wrong}:" in d and "error[" in d]
    assert said, f"nothing names {wrong}:\n{err}"
    message = said[0]
    assert re.search(rf"{re.escape(str(wrong))}: is [^\n]*, not ", message), message
    assert "= help: " in message, message
    assert not os.path.exists(paths.out), "an output was written"
