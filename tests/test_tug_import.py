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


SLIPS = Path(__file__).parent / "tug" / "knapp_slips.yaml"


def test_a_name_with_white_space_around_it_is_trimmed_with_a_warning_at_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The real configuration's '/tf ' (issue 38): RAC028 before, and the whole generated
    model printed to standard error."""
    out = tmp_path / "paul.ram"
    assert main(["import", "tug", str(SLIPS), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    lines = SLIPS.read_text(encoding="utf-8").splitlines()
    line = next(k for k, text in enumerate(lines, 1) if "pub_topic: [\"/odom\", '/tf '" in text)
    column = lines[line - 1].index("'/tf '") + 1
    assert f"{SLIPS}:{line}:{column}: warning[RAC180]: node ose800_can_driver: pub_topic " in err
    assert "holds '/tf ': the white space around the name is no part of it, read as '/tf'" in err
    assert "Imported from the tug_diagnosis" not in err  # the model is written, not dumped
    text = out.read_text(encoding="utf-8")
    assert f"# import: line {line}: node ose800_can_driver: pub_topic holds '/tf '" in text
    assert [t for t in text.splitlines() if t.startswith("topic /tf")] == ["topic /tf @ 10 Hz"]
    nodes = load_theory(str(out)).components
    assert "ose800_can_driver" in nodes and "sick_front" in nodes


def test_an_error_of_the_model_points_at_the_configurations_line_and_dumps_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tug.yaml"
    config.write_text(
        "nodes:\n"
        "  - name: driver\n"
        "    pub_topic: ['/scan']\n"
        "  - name: mapper\n"
        "    sub_topic: ['/scan']\n"
        "    pub_topic: ['/map view']\n",
        encoding="utf-8",
    )
    out = tmp_path / "robot.ram"
    assert main(["import", "tug", str(config), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert f"{config}:6:17: error[RAC028]: invalid ROS topic name '/map view'" in err
    assert "   6 |     pub_topic: ['/map view']" in err
    assert "robot tug" not in err and "node mapper" not in err
    assert not out.exists()


def test_a_malformed_entry_is_located(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = tmp_path / "tug.yaml"
    config.write_text("nodes:\n  - name: a\n  - pub_topic: [/x]\n", encoding="utf-8")
    assert main(["import", "tug", str(config), "-o", str(tmp_path / "x.ram")]) == 1
    assert f"{config}:3:5: error[RAC064]: {config}: nodes[1] has no name" in capsys.readouterr().err
