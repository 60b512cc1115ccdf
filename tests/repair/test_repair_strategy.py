"""The minimal strategy plans for the repairable minimum-cardinality diagnoses."""

from __future__ import annotations

from pathlib import Path

import pytest

from rac.cli import main
from rac.repair.choice import choose_bad

MODELS = Path(__file__).resolve().parents[2] / "models"


def test_union_of_minimum_cardinality_diagnoses() -> None:
    diagnoses = (("jaguar",), ("jaguar_node",), ("a", "b"))
    assert choose_bad(diagnoses, "minimal") == ("jaguar", "jaguar_node")
    assert choose_bad(diagnoses, "first") == ("jaguar",)


def test_unrepairable_diagnoses_are_left_out_while_another_can_be_repaired() -> None:
    diagnoses = (("p2os",), ("pioneer_base",))
    fixable = {"p2os"}.__contains__
    assert choose_bad(diagnoses, "minimal", fixable) == ("p2os",)
    # When nothing is repairable the union stays, so the error can name the hardware.
    assert choose_bad(diagnoses, "minimal", lambda c: False) == ("p2os", "pioneer_base")


def test_pioneer_base_fault_restarts_its_driver_and_names_the_base(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["repair", str(MODELS / "pioneer.ram"), "--obs", "not ok(pioneer_base)"]
    argv += ["--obs", "running(p2os)"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "1. stop_node(p2os)" in out and "2. start_node(p2os)" in out
    assert "{pioneer_base}" in out.splitlines()[-1]
