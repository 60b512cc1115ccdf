"""Issue 11: what a new user tripped over (the error-message points have goldens in
``tests/errors/`` and ``tests/errors/commands/``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rac.cli import main

ROOT = Path(__file__).resolve().parent.parent
TEDUSAR = str(ROOT / "models" / "tedusar.ram")


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_obs_accepts_ros_names_mangled_like_the_compiler(
    capsys: pytest.CaptureFixture[str],
) -> None:
    plain = _run(
        ["diagnose", TEDUSAR, "--obs", "not ok(pose)", "--obs", "ok(imu_data)", "--json"], capsys
    )
    ros = _run(
        ["diagnose", TEDUSAR, "--obs", "not ok(/pose)", "--obs", "ok(imu/data)", "--json"], capsys
    )
    assert plain[0] == ros[0] == 0
    assert json.loads(ros[1]) == json.loads(plain[1])


def test_check_takes_several_models_and_q(capsys: pytest.CaptureFixture[str]) -> None:
    models = sorted(str(p) for p in (ROOT / "models").glob("*.ram"))
    code, out, _ = _run(["check", *models], capsys)
    assert code == 0 and len(out.splitlines()) == len(models)
    code, out, err = _run(["check", "-q", *models], capsys)
    assert (code, out, err) == (0, "", "")


def test_check_reports_every_bad_model(capsys: pytest.CaptureFixture[str]) -> None:
    bad = str(ROOT / "tests" / "errors" / "RAC011_undefined_hardware.ram")
    code, out, err = _run(["check", TEDUSAR, bad], capsys)
    assert code == 1 and "tedusar.ram: ok" in out and "error[RAC011]" in err


def test_every_command_takes_q() -> None:
    from rac.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, command in sub.choices.items():  # type: ignore[attr-defined]
        assert any("-q" in a.option_strings for a in command._actions), name


def test_summaries_use_singular_for_one(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "one.ram"
    model.write_text("robot one\nhardware h\ntopic /t\nnode n drives h { publishes /t }\n")
    code, out, _ = _run(["check", str(model)], capsys)
    assert code == 0
    assert "(1 node, 1 hardware, 1 topic, 1 component, 0 warnings)" in out, out
