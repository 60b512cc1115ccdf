"""What an audit of the command lines against docs/spec.md found: each test failed before
its fix."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
FULL_ADDER = str(ROOT / "tests" / "diagnosis" / "full_adder.yaml")


@pytest.mark.parametrize(
    ("argv", "usage"),
    [
        (["compile", TEDUSAR, "-o", "unused", "--bogus"], "usage: racc compile "),
        (["diagnose", TEDUSAR, "--obs", "ok(pose)", "--obs", "ok(scan)", "extra"], "racc diagnose"),
        (["board", "status", "--board", "127.0.0.1:1", "--nope"], "usage: racc board status "),
    ],
)
def test_an_unknown_argument_shows_the_commands_own_usage(
    argv: list[str], usage: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2
    assert usage in err and f"error: unrecognized arguments: {argv[-1]}" in err
    assert "usage: racc [-h]" not in err


@pytest.mark.parametrize(
    "argv",
    [
        ["compile", FULL_ADDER, "-o", "unused"],
        ["check", FULL_ADDER],
        ["export", "--json", FULL_ADDER],
        ["place", FULL_ADDER],
    ],
)
def test_commands_that_need_the_architecture_say_so_for_a_model_yaml(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "error[RAC060]" in err and "expected 'robot'" not in err


def test_a_write_error_names_the_file_asked_for_not_a_temp_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "missing" / "problem.pddl"
    argv = ["repair", TEDUSAR, "--obs", "not ok(pose)", "--problem-out", str(target)]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert f"error[RAC004]: {target}: cannot write: No such file or directory" in err
    assert ".problem.pddl." not in err


def test_an_observation_file_that_is_a_directory_is_no_model_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["diagnose", TEDUSAR, "--obs-file", str(tmp_path)]) == 1
    assert f"{tmp_path}: is a directory, not an observations file" in capsys.readouterr().err


def test_record_without_ros_1_is_an_input_error_not_a_crash(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "rospy", None)  # importing it raises ImportError
    monkeypatch.setitem(sys.modules, "rosgraph", None)
    argv = ["record", "--ros", "1", "-o", str(tmp_path / "run.bag"), "--duration", "1"]
    assert main(argv) == 1
    assert "error[RAC057]" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("ros", "module", "code"), [("1", "rospy", "RAC057"), ("2", "rclpy", "RAC116")]
)
def test_demo_without_the_ros_client_library_starts_nothing(
    ros: str,
    module: str,
    code: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import subprocess

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError(f"started a process: {args}")

    monkeypatch.setitem(sys.modules, module, None)
    monkeypatch.setattr(subprocess, "Popen", refuse)
    assert main(["demo", TEDUSAR, "--ros", ros, "-o", str(tmp_path / "demo")]) == 1
    out, err = capsys.readouterr()
    assert f"error[{code}]" in err
    # Nor writes a package whose executables would run this Python (without ROS): no
    # "wrote ... export ..." above the error.
    assert not (tmp_path / "demo").exists() and "wrote" not in out
    # --write-only needs no ROS.
    assert main(["demo", TEDUSAR, "--ros", ros, "-o", str(tmp_path / "w"), "--write-only"]) == 0


def test_a_missing_planner_named_by_the_environment_says_which_path(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("RACC_FAST_DOWNWARD", "/nonexistent/fast-downward.py")
    assert main(["repair", TEDUSAR, "--obs", "not ok(pose)"]) == 3
    err = capsys.readouterr().err
    assert "error[RAC072]" in err and "RACC_FAST_DOWNWARD=/nonexistent/fast-downward.py" in err


@pytest.mark.parametrize("command", ["diagnose", "simulate"])
def test_with_good_without_json_is_a_command_line_error(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [command, TEDUSAR, "--with-good"]
    argv += ["--obs", "not ok(pose)"] if command == "diagnose" else ["--fault", "imu_node"]
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert f"racc {command}: error: --with-good goes with --json" in capsys.readouterr().err


def test_fmt_refuses_a_json_or_model_yaml_before_rewriting_anything(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ram = tmp_path / "robot.ram"
    ram.write_text(Path(TEDUSAR).read_text(encoding="utf-8") + "\n\n\n", encoding="utf-8")
    before = ram.read_text(encoding="utf-8")
    other = tmp_path / "robot.json"
    other.write_text("{}", encoding="utf-8")
    assert main(["fmt", str(ram), str(other), FULL_ADDER]) == 1
    err = capsys.readouterr().err
    assert f"error[RAC060]: {other}: racc fmt formats .ram files only" in err
    assert f"error[RAC060]: {FULL_ADDER}: racc fmt formats .ram files only" in err
    assert ram.read_text(encoding="utf-8") == before  # nothing rewritten: all or nothing


def test_export_to_a_file_says_what_it_wrote(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tedusar.json"
    assert main(["export", TEDUSAR, "--json", "-o", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().err
    assert out.read_text(encoding="utf-8").startswith("{")
    assert main(["export", TEDUSAR, "--json", "-o", str(out), "-q"]) == 0
    assert capsys.readouterr().err == ""
