"""racc diagram and the diagram options of compile and replay: formats, errors, views."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import foreign_bag
import pytest
from diagram_robots import synthetic_robot

from rac.cli import main
from rac.fmt import format_model
from rac.ir import Model, Name, Node, Publication, Topic
from rac.targets.dot import SUMMARY_ABOVE_NODES, summarised

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
PIONEER = str(ROOT / "models" / "pioneer.ram")
WAREHOUSE = str(ROOT / "models" / "warehouse.ram")
HAVE_DOT = shutil.which("dot") is not None


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_dot_goes_to_stdout_and_a_dot_file_needs_no_graphviz(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    code, out, _ = run(capsys, "diagram", TEDUSAR, "--analysis", "no")
    assert code == 0 and out.startswith("// The architecture of robot")
    monkeypatch.setattr(shutil, "which", lambda name: None)  # no Graphviz at all
    code, out, _ = run(
        capsys, "diagram", TEDUSAR, "--analysis", "no", "-o", str(tmp_path / "t.dot")
    )
    assert code == 0 and "wrote" in out
    assert (tmp_path / "t.dot").read_text().startswith("// The architecture")
    code, _, err = run(capsys, "diagram", TEDUSAR, "-o", str(tmp_path / "t.svg"))
    assert code == 1 and "error[RAC065]" in err and "apt-get install graphviz" in err
    assert not (tmp_path / "t.svg").exists()


@pytest.mark.skipif(not HAVE_DOT, reason="Graphviz dot is not installed")
@pytest.mark.parametrize(
    "suffix, magic", [(".svg", b"<?xml"), (".png", b"\x89PNG"), (".pdf", b"%PDF")]
)
def test_the_suffix_picks_the_format(
    suffix: str, magic: bytes, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / f"t{suffix}"
    code, _, _ = run(capsys, "diagram", TEDUSAR, "-o", str(out), "-q")
    assert code == 0 and out.read_bytes().startswith(magic)


def test_errors_a_user_meets(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "diagram", TEDUSAR, "-o", str(tmp_path / "t.txt"))
    assert code == 1 and "error[RAC068]" in err and ".svg" in err
    code, _, err = run(capsys, "diagram", TEDUSAR, "--focus", "/poze")
    assert code == 1 and "error[RAC066]" in err and "did you mean /pose" in err
    code, _, err = run(capsys, "diagram", TEDUSAR, "--diagnosis", "jaguar_node,nobody")
    assert code == 1 and "error[RAC067]" in err and "nobody" in err
    with pytest.raises(SystemExit) as stop:
        main(["diagram", TEDUSAR, "--depth", "-1"])
    assert stop.value.code == 2 and "must be 0 or more" in capsys.readouterr().err


def test_a_focus_and_a_diagnosis_from_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "f.dot"
    code, _, _ = run(
        capsys, "diagram", WAREHOUSE, "--focus", "/robot_41/localization/amcl", "-o", str(out), "-q"
    )
    text = out.read_text()
    assert code == 0 and '"/robot_41/localization/amcl"' in text
    assert '"/robot_41/drivers/plc_bridge"' not in text
    code, _, _ = run(capsys, "diagram", TEDUSAR, "--diagnosis", "jaguar_node", "-o", str(out), "-q")
    text = out.read_text()
    assert code == 0 and '"jaguar_node" [fillcolor="#555555", fontcolor="#ffffff", ' in text
    assert 'fillcolor="#e53935"' in text and "diagnosis: jaguar_node" in text


def test_observations_are_diagnosed_and_drawn(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "o.dot"
    code, _, _ = run(
        capsys,
        "diagram",
        TEDUSAR,
        "--obs",
        "not ok(pose)",
        "--obs",
        "running(jaguar_node)",
        "--obs",
        "on(jaguar)",
        "-o",
        str(out),
        "-q",
    )
    text = out.read_text()
    assert code == 0
    assert "3 observations, 1 bad: minimal diagnoses {jaguar} | {jaguar_node}" in text
    assert text.count('fillcolor="#ffb74d"') == 2  # both suspects


def test_the_analysis_marks_unseen_faults_by_default(capsys: pytest.CaptureFixture[str]) -> None:
    _, out, _ = run(capsys, "diagram", TEDUSAR)
    assert "unseen: output" in out and "not analysed" not in out
    _, out, _ = run(capsys, "diagram", TEDUSAR, "--analysis", "no")
    assert "unseen" not in out.split("label=<", 1)[1] and "not analysed" in out


def big_model(nodes: int) -> Model:
    topics = tuple(Topic(Name(f"/a{i % 5}/t{i}"), "m/M") for i in range(nodes))
    built = tuple(
        Node(
            Name(f"/a{i % 5}/n{i}"),
            subscribes=(Name(f"/a{(i - 1) % 5}/t{i - 1}"),) if i else (),
            publishes=(Publication(Name(f"/a{i % 5}/t{i}")),),
        )
        for i in range(nodes)
    )
    return Model(Name("big"), (), topics, built)


def test_compile_writes_the_summary_of_a_large_model_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "big.ram"
    model.write_text(format_model(big_model(SUMMARY_ABOVE_NODES + 1)))
    code, _, err = run(capsys, "compile", str(model), "-o", str(tmp_path / "out"), "--no-svg")
    assert code == 0
    assert f"note: {SUMMARY_ABOVE_NODES + 1} nodes (over {SUMMARY_ABOVE_NODES}): " in err
    text = (tmp_path / "out" / "architecture.dot").read_text()
    assert '"group:/a0"' in text and '"/a0/n0"' not in text
    code, out, _ = run(capsys, "diagram", str(model), "--all", "--analysis", "no")
    assert '"/a0/n0"' in out and "group:" not in out


@pytest.mark.slow
def test_replay_draws_the_diagnosis_at_a_moment(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag, csv = tmp_path / "robot.bag", tmp_path / "robot_properties.csv"
    foreign_bag.write(bag, csv)
    stopped = foreign_bag.FAULTS[0]  # ("stopped topic", "/scan", 40.0, 60.0, "sicklms")
    out = tmp_path / "at.dot"
    at = str(stopped[2] + 15.0)
    args = [PIONEER, str(bag), "--properties", str(csv), "--diagram-at", at, "--diagram", str(out)]
    code, _, _ = run(capsys, "replay", *args, "-q")
    assert code == 0
    text = out.read_text()
    assert f"replay at {float(at):g} s" in text
    scan = next(line for line in text.splitlines() if "/scan @" in line and "label=" in line)
    assert 'COLOR="#c62828"' in scan  # its rate observer reads bad
    sick = next(line for line in text.splitlines() if line.strip().startswith('"sicklms" ['))
    assert "#e53935" in sick or "#ffb74d" in sick  # diagnosed


@pytest.mark.slow
def test_the_text_is_the_same_whatever_the_hash_seed() -> None:
    import os
    import subprocess
    import sys

    texts = set()
    views = (["--summary"], ["--all", "--analysis", "no"], ["--nodes", "--analysis", "no"])
    for seed in ("1", "2", "3"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        for view in views:
            done = subprocess.run(
                [sys.executable, "-m", "rac", "diagram", WAREHOUSE, *view, "-q"],
                capture_output=True,
                env=env,
                check=True,
            )
            texts.add((view[0], done.stdout))
    assert len(texts) == len(views)


def test_replay_checks_the_diagram_file_before_replaying(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    missing = str(tmp_path / "missing.bag")
    code, _, err = run(
        capsys, "replay", PIONEER, missing, "--diagram-at", "1", "--diagram", "x.txt"
    )
    assert code == 1 and "error[RAC068]" in err and "missing.bag" not in err


def test_the_view_is_chosen_by_size_or_by_flag(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "t.dot")
    code, said, _ = run(capsys, "diagram", TEDUSAR, "-o", out, "--analysis", "no")
    assert code == 0 and "(the topic view of 9 nodes," in said
    code, said, _ = run(capsys, "diagram", TEDUSAR, "-o", out, "--analysis", "no", "--nodes")
    assert code == 0 and "(the node view of 9 nodes," in said
    code, said, _ = run(capsys, "diagram", WAREHOUSE, "-o", out, "--analysis", "no")
    assert code == 0 and "(the node view of 31 nodes," in said
    code, said, _ = run(capsys, "diagram", WAREHOUSE, "-o", out, "--analysis", "no", "--topics")
    assert code == 0 and "(the topic view of 31 nodes," in said
    with pytest.raises(SystemExit) as stop:
        main(["diagram", TEDUSAR, "--nodes", "--topics"])
    assert stop.value.code == 2


def test_a_focus_says_how_many_of_the_models_nodes_it_drew(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 37: the focus view's message counted every node of the model."""
    out = str(tmp_path / "f.dot")
    amcl = "/robot_41/localization/amcl"
    code, said, _ = run(capsys, "diagram", WAREHOUSE, "--focus", amcl, "-o", out)
    found = re.findall(r'^  +"(/robot_41/[^"]+)" \[', Path(out).read_text(), re.M)
    drawn = {name for name in found if " → " not in name}  # not an arrow's label
    assert code == 0 and f"(the topic view of {len(drawn)} of 31 nodes," in said
    assert len(drawn) < 31


def test_a_namespace_opens_with_its_neighbours_as_boxes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "ns.dot"
    code, _, _ = run(
        capsys, "diagram", WAREHOUSE, "--focus", "/robot_41/localization", "-o", str(out), "-q"
    )
    text = out.read_text()
    assert code == 0
    assert (
        '"/robot_41/localization/amcl" [' in text
        and '"/robot_41/localization/map_server" [' in text
    )
    assert '"/robot_41/navigation/move_base" [' not in text  # outside: in its box
    assert '"group:/robot_41/drivers" [' in text and '"group:/robot_41/navigation" [' in text
    assert "focus: namespace /robot_41/localization, 0 hop(s)" in text
    code, _, err = run(capsys, "diagram", WAREHOUSE, "--focus", "/robot_41/localisation")
    assert code == 1 and "error[RAC066]" in err and "did you mean /robot_41/localization" in err


@pytest.mark.slow
def test_a_300_node_robot_gets_the_summary_and_its_namespaces_open(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "big.ram"
    model.write_text(format_model(synthetic_robot(300, 12)), "utf-8")
    out = tmp_path / "s.dot"
    code, said, _ = run(capsys, "diagram", str(model), "-o", str(out))
    text = out.read_text()
    assert code == 0 and "(the summary of 300 nodes," in said
    boxes = re.findall(r'^  +"group:(/robot/[a-z]+\d+)" \[', text, re.M)
    assert len(boxes) == 12 and f"--focus {boxes[3]} opens it" in text
    code, said, _ = run(capsys, "diagram", str(model), "--focus", boxes[3], "-o", str(out))
    text = out.read_text()
    assert code == 0 and "(the node view of 25 of 300 nodes," in said
    inside = re.findall(rf'^  +"({boxes[3]}/[^"→]+)" \[', text, re.M)
    assert len(inside) == 25 and '"group:' in text


def test_a_robot_of_one_namespace_is_summarised_only_above_300_nodes() -> None:
    """Its summary is one box: up to 300 nodes it gets the node view (Graphviz: 9 s at 300),
    above the box again, as before (the full drawing would pass compile's 120 s)."""
    assert not summarised(synthetic_robot(SUMMARY_ABOVE_NODES + 1, 1))
    assert not summarised(synthetic_robot(300, 1))
    assert summarised(synthetic_robot(301, 1))
    assert summarised(synthetic_robot(SUMMARY_ABOVE_NODES + 1, 2))
    assert not summarised(synthetic_robot(SUMMARY_ABOVE_NODES, 2))
