"""``racc import tug``: tug_diagnosis configurations as .ram models."""

from __future__ import annotations

from pathlib import Path

import pytest

from rac.cli import main
from rac.diagnosis import Literal, diagnose
from rac.load.theory import load_theory
from rac.logic import Atom
from rac.tug import import_tug

KNAPP = Path(__file__).parent / "tug" / "knapp.yaml"


def test_import_writes_a_valid_model_with_its_loop(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "knapp.ram"
    assert main(["import", "tug", str(KNAPP), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "RAC104" in err and "ose800_can_driver" in err
    for kind in ("timeout", "timestamp", "timing", "velocity", "resources"):
        assert f"{kind} on" in err
    assert "topic /odom @ 10 Hz" in out.read_text()
    theory = load_theory(str(out))
    result = diagnose(theory, [Literal(Atom("ok", ("odom",)), False)])
    assert not result.consistent  # the loop rule: a healthy loop derives ok(odom)


def test_every_output_depends_on_every_other_input() -> None:
    imported = import_tug(KNAPP.read_text(), str(KNAPP), "knapp")
    nodes = imported.model.node_by_name()
    rsp = nodes["robot_state_publisher"].publishes[0]
    assert rsp.topic.value == "/tf" and [i.value for i in rsp.affected_by] == ["/joint_states"]
    assert any("Proposition 4.1" in n for n in imported.notes)


@pytest.mark.parametrize(
    "text", ["nodes: 3\n", "- a\n", "nodes:\n  - pub_topic: [/a]\n", "nodes: []\nobservations: 1\n"]
)
def test_malformed_configuration(
    tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    assert main(["import", "tug", str(bad), "-o", str(tmp_path / "x.ram")]) == 1
    assert "RAC064" in capsys.readouterr().err
    assert not (tmp_path / "x.ram").exists()
