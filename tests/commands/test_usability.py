"""Issue 11: what a new user tripped over (the error-message points have goldens in
``tests/errors/`` and ``tests/errors/commands/``)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterator
from pathlib import Path
from typing import cast

import pytest

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
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


def _subcommands(action: argparse.Action) -> dict[str, argparse.ArgumentParser]:
    """The parsers of a subparsers action (argparse types its choices as any iterable)."""
    return cast("dict[str, argparse.ArgumentParser]", action.choices)


def test_every_command_takes_q() -> None:
    from rac.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, command in _subcommands(sub).items():
        assert any("-q" in a.option_strings for a in command._actions), name


def test_summaries_use_singular_for_one(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "one.ram"
    model.write_text("robot one\nhardware h\ntopic /t\nnode n drives h { publishes /t }\n")
    code, out, _ = _run(["check", str(model)], capsys)
    assert code == 0
    assert "(1 node, 1 hardware, 1 topic, 1 component, 0 warnings)" in out, out


@pytest.mark.parametrize("name", ["tedusar", "pioneer"])
def test_power_up_starts_publishers_before_their_subscribers(name: str) -> None:
    from rac.load.theory import load_theory
    from rac.logic import mangle
    from rac.repair.order import flow_ranks
    from rac.repair.scenario import run_scenario

    theory = load_theory(str(ROOT / "models" / f"{name}.ram"))
    assert theory.model is not None
    plan = run_scenario(theory, name, "power-up").repair.plan
    started = [s[1] for s in plan if s[0] == "start_node"]
    ranks = flow_ranks(theory.model)
    assert [ranks[n] for n in started] == sorted(ranks[n] for n in started), started
    publishers = {t: mangle(n.name.value) for n in theory.model.nodes for t in n.published_topics}
    for node in theory.model.nodes:
        for topic in node.subscribes:
            pub = publishers.get(topic.value)
            if pub is not None and ranks[pub] < ranks[mangle(node.name.value)]:
                assert started.index(pub) < started.index(mangle(node.name.value))


OBS = ["--obs", "on(jaguar)", "--obs", "running(jaguar_node)", "--obs", "not ok(pose)"]


@pytest.mark.slow
def test_repair_says_the_plan_was_validated(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(["repair", TEDUSAR, *OBS, "--validate"], capsys)
    assert code == 0 and "plan validated" in out
    code, out, _ = _run(["repair", TEDUSAR, *OBS, "--validate", "--json"], capsys)
    assert code == 0 and json.loads(out)["validated"] is True
    code, out, _ = _run(["repair", TEDUSAR, *OBS, "--json"], capsys)
    assert "validated" not in json.loads(out)


def test_repair_explains_why_it_repairs_several_candidates(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, _ = _run(["repair", TEDUSAR, *OBS], capsys)
    assert code == 0
    assert "cannot yet tell {jaguar} or {jaguar_node} apart" in out
    assert "add observers" in out


def test_repair_takes_max_card(capsys: pytest.CaptureFixture[str]) -> None:
    obs = ["--obs", "not running(joy_node)", "--obs", "not running(rviz)"]
    code, out, err = _run(["repair", TEDUSAR, *obs, "--max-card", "1", "--json"], capsys)
    assert code == 3 and "bounded at 1" in err
    code, out, _ = _run(["repair", TEDUSAR, *obs, "--max-card", "2", "--json"], capsys)
    assert code == 0 and json.loads(out)["diagnosis"]["bad"] == ["joy_node", "rviz"]


def test_help_metavars_match_their_text() -> None:
    from rac.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, command in _subcommands(sub).items():
        text = command.format_help()
        if "KIND@T[+D]:TARGET" in (command.description or ""):
            assert "KIND@T:TARGET" not in text, name
        for action in command._actions:
            if any(o.endswith("-port") for o in action.option_strings):
                assert action.metavar == "PORT", (name, action.option_strings)


def test_help_descriptions_are_wrapped() -> None:
    import os

    from rac.cli import build_parser

    os.environ["COLUMNS"] = "100"
    try:
        parser = build_parser()
        sub = next(a for a in parser._actions if a.dest == "command")
        for name, command in _subcommands(sub).items():
            for line in command.format_help().splitlines():
                if not line.startswith(("  racc ", "  roslaunch ")):  # examples kept as written
                    assert len(line) <= 100, (name, line)
    finally:
        del os.environ["COLUMNS"]


def test_every_option_is_explained_with_its_default() -> None:
    """Each option of each command (subcommands too) has help, and a default is stated."""
    import argparse

    from rac.cli import build_parser

    def parsers(
        parser: argparse.ArgumentParser, name: str
    ) -> Iterator[tuple[str, argparse.ArgumentParser]]:
        yield name, parser
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub_name, sub in action.choices.items():
                    yield from parsers(sub, f"{name} {sub_name}".strip())

    silent = (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction)
    for name, parser in parsers(build_parser(), ""):
        for action in parser._actions:
            if isinstance(action, silent) or action.help == argparse.SUPPRESS:
                continue
            where = (name, action.option_strings or action.dest)
            assert action.help, where
            stated = isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction))
            if action.option_strings and action.default not in (None, False, [], ()):
                assert stated or "default" in action.help, where
