"""Issue 26: what a new user tripped over, second pass (messages, output, real inputs).
The live points (racc run, racc watch, the demo) are in tests/ros1 and tests/ros2."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest

from rac.cli import main
from rac.errors import Diagnostic

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_fmt_hints_a_command_that_works_and_none_for_model_yaml(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "tedusar.json"
    assert _run(["export", "--json", TEDUSAR, "-o", str(model)], capsys)[0] == 0
    code, _, err = _run(["fmt", str(model)], capsys)
    assert code == 1 and "RAC060" in err
    hint = err.split("help: ")[1].split("'")[1]
    argv = shlex.split(hint)
    assert argv[0] == "racc"
    assert _run(argv[1:], capsys)[0] == 0  # the hint's own command works
    assert (tmp_path / "tedusar.ram").read_text().startswith("robot tedusar")
    yaml = tmp_path / "model.yaml"
    yaml.write_text("robot: x\n")
    code, _, err = _run(["fmt", str(yaml)], capsys)
    assert code == 1 and "racc export" not in err and "compiled from" in err


@pytest.mark.slow
def test_diagnose_reads_the_model_yaml_compile_writes_for_50000_nodes(tmp_path: Path) -> None:
    """model.yaml of a 50,000-node robot is 19.6 MB, beyond the YAML composer's 16 MiB
    limit: it is read line by line, as racc writes it (RAC009 before)."""
    import sys

    sys.path.insert(0, str(ROOT / "bench"))
    try:
        from compile import synthetic_model
    finally:
        sys.path.remove(str(ROOT / "bench"))
    from rac.limits import MAX_YAML_BYTES
    from rac.load.theory import load_theory
    from rac.pipeline import compile_model
    from rac.targets import EmitOptions
    from rac.targets.model_yaml import emit_model_yaml

    model = synthetic_model(50_000)
    text = emit_model_yaml(compile_model(model), EmitOptions())
    assert len(text) > MAX_YAML_BYTES
    path = tmp_path / "model.yaml"
    path.write_text(text, encoding="utf-8")
    theory = load_theory(str(path))
    assert len(theory.components) >= 50_000


def _codes_and_hints(text: str) -> list[tuple[str, str | None]]:
    from rac.errors import RacError
    from rac.parse import parse_ram
    from rac.pipeline import check_model

    try:
        found = check_model(parse_ram(text, "robot.ram"))
    except RacError as err:
        found = err.diagnostics
    return [(d.code, d.hint) for d in found if d.severity == "error"]


def test_a_misspelt_input_is_one_error_not_three() -> None:
    text = """robot r
topic /scan : sensor_msgs/LaserScan @ 10 Hz
topic /odom : nav_msgs/Odometry @ 10 Hz
topic /cmd_vel : geometry_msgs/Twist
node laser { publishes /scan }
node odo { publishes /odom }
node nav {
  subscribes /scan, /odm
  publishes /cmd_vel from /scan, /odom
}
node base { subscribes /cmd_vel }
"""
    assert _codes_and_hints(text) == [("RAC012", "did you mean '/odom'?")]


def test_an_undeclared_topic_is_one_error_that_says_to_declare_it() -> None:
    text = """robot r
topic /scan : sensor_msgs/LaserScan @ 10 Hz
node laser { publishes /scan }
node planner { publishes /goal }
node nav { subscribes /scan, /goal }
node arm { subscribes /goal }
"""
    found = _codes_and_hints(text)
    assert len(found) == 1 and found[0][0] == "RAC012"
    assert "declare it: 'topic /goal" in (found[0][1] or "")
    assert "'arm', 'nav'" in (found[0][1] or "")


def _diagnostics(text: str) -> list[Diagnostic]:
    from rac.errors import RacError
    from rac.parse import parse_ram
    from rac.pipeline import check_model

    try:
        return list(check_model(parse_ram(text, "robot.ram")))
    except RacError as err:
        return list(err.diagnostics)


@pytest.mark.parametrize(
    ("written", "unit", "column"),
    [("mem 1 Gb", "GB", 16), ("mem 1 mb", "MB", 16), ("cpu 5 %, mem 2 kb", "kB", 25)],
)
def test_a_unit_in_the_wrong_case_gets_its_caret_and_a_did_you_mean(
    written: str, unit: str, column: int
) -> None:
    text = f"robot r\ntopic /a @ 10 Hz\nnode n {{\n  publishes /a\n  limits {written}\n}}\n"
    (d,) = _diagnostics(text)
    assert d.code == "RAC001" and d.hint == f"did you mean '{unit}'?"
    assert d.span is not None
    assert d.span.column == column


def test_a_rate_unit_in_the_wrong_case() -> None:
    (d,) = _diagnostics("robot r\ntopic /a @ 10 hz\nnode n { publishes /a }\n")
    assert d.span is not None
    assert d.hint == "did you mean 'Hz'?" and d.span.column == 15


def test_a_tolerance_error_gives_the_values() -> None:
    (d,) = _diagnostics("robot r\ntopic /a @ 10 Hz +- 20 Hz\nnode n { publishes /a }\n")
    assert d.code == "RAC029" and "20 Hz" in d.message and "10 Hz" in d.message


# Each rate option has a span of its own: the caret is under the option, not the whole line.
@pytest.mark.parametrize(
    ("declaration", "code", "said", "columns"),
    [
        ("topic /a @ 10 Hz +- 20 Hz", "RAC029", "tolerance 20 Hz", (18, 26)),
        ("topic /a @ 10 Hz mismatch 2 ± 20 Hz window 2 s", "RAC029", "tolerance 20", (29, 36)),
        ("topic /a @ 10 Hz window 500 s", "RAC133", "window 500 s", (18, 30)),
        ("topic /a @ 10 Hz\n  window 0 ms", "RAC029", "not 0 s", (3, 14)),
        ("topic /a @ 0 Hz", "RAC029", "not 0 Hz", (10, 16)),
        ("topic /a @ 1e-320 Hz +- 0 Hz", "RAC007", "too close to 0", (10, 21)),
    ],
)
def test_a_rate_option_error_points_at_the_option(
    declaration: str, code: str, said: str, columns: tuple[int, int]
) -> None:
    text = f"robot r\n{declaration}\nnode n {{ publishes /a }}\n"
    (d,) = [d for d in _diagnostics(text) if d.code == code]
    assert said in d.message
    assert d.span is not None
    assert (d.span.column, d.span.end_column) == columns


@pytest.mark.parametrize(("window", "warned"), [("500 s", True), ("50 ms", True), ("2 s", False)])
def test_a_window_far_outside_its_rate_is_warned(window: str, warned: bool) -> None:
    text = f"robot r\ntopic /a @ 10 Hz window {window}\nnode n {{ publishes /a }}\n"
    codes = [d.code for d in _diagnostics(text)]
    assert ("RAC133" in codes) == warned


def test_tug_import_reads_an_empty_topic_name_as_none(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tug.yaml"
    config.write_text(
        "nodes:\n"
        "  - name: driver\n    pub_topic: [/scan]\n    sub_topic: ['']\n"
        "  - name: mapper\n    pub_topic: ['/map']\n    sub_topic: [/scan]\n"
    )
    out = tmp_path / "robot.ram"
    code, _, err = _run(["import", "tug", str(config), "-o", str(out)], capsys)
    assert code == 0, err
    assert "node driver: sub_topic holds an empty name, read as none" in out.read_text()
    from rac.tug import import_tug

    nodes = import_tug(config.read_text(), str(config), "r").model.node_by_name()
    assert nodes["driver"].subscribes == ()


@pytest.fixture(scope="module")
def crash_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("replay") / "run.bag"
    argv = ["synth", TEDUSAR, "-o", str(run), "--duration", "30", "--fault", "crash@10:joy_node"]
    assert main([*argv, "-q"]) == 0
    return run


@pytest.mark.slow
def test_a_faults_file_without_robot_and_duration_is_used(
    crash_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    faults = crash_run.with_name("run.faults.yaml")
    faults.write_text(
        "faults:\n- kind: crash\n  target: joy_node\n  start: 10.0\n  culprits: [joy_node]\n"
    )
    code, out, err = _run(["replay", TEDUSAR, str(crash_run)], capsys)
    assert code == 0, err
    assert "RAC085" not in err and "without ground truth" not in err
    # scored against the truth, the fault lasting to the end of the 30 s recording
    assert "fault crash joy_node 10-29.9" in out and "reported at" in out


@pytest.mark.slow
def test_replay_goes_on_without_an_unusable_faults_file(
    crash_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    faults = crash_run.with_name("run.faults.yaml")
    faults.write_text("faults: 3\n")
    code, out, err = _run(["replay", TEDUSAR, str(crash_run)], capsys)
    assert code == 0, err
    assert "episode 1" in out  # replayed, unscored
    assert "not a usable faults file (RAC085" in err and "replaying without ground truth" in err


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", TEDUSAR, "--all-single-faults", "--json"],
        ["analyze", TEDUSAR, "--json"],
        ["place", TEDUSAR, "--json"],
        ["diagnose", TEDUSAR, "--obs", "not ok(pose)", "--json"],
    ],
)
def test_json_is_one_line_and_pretty_indents_it(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = _run(argv, capsys)
    assert code == 0 and len(out.strip().splitlines()) == 1
    code, pretty, _ = _run([*argv, "--pretty"], capsys)
    assert code == 0 and pretty.startswith("{\n  ")
    assert json.loads(pretty) == json.loads(out)


def test_simulate_explains_a_fault_not_isolated_without_an_ambiguity_group() -> None:
    from rac.commands.simulate import table_report
    from rac.diagnosis import DiagnosisResult, Simulation, ambiguity_groups

    comps = ("lidar", "lidar_driver", "mapper")
    alone = DiagnosisResult(False, (), (("lidar_driver",), ("lidar", "mapper")), comps, False)
    isolated = DiagnosisResult(False, (), (("mapper",),), comps, False)
    sims = [
        Simulation(("lidar_driver",), (), alone, "output"),
        Simulation(("mapper",), (), isolated, "output"),
    ]
    groups = ambiguity_groups(sims)
    text = table_report(tuple(sims), groups, "output")
    assert groups == () and "none among the detected faults" not in text
    assert (
        "not isolated: lidar_driver: its symptoms are explained as well by {lidar, mapper}" in text
    )


@pytest.mark.slow
def test_replay_says_why_it_replays_fewer_messages_than_recorded(
    crash_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from rosbags.highlevel import AnyReader

    with AnyReader([crash_run]) as reader:
        recorded = reader.message_count
    crash_run.with_name("run.faults.yaml").unlink(missing_ok=True)
    code, out, err = _run(["replay", TEDUSAR, str(crash_run)], capsys)
    assert code == 0, err
    assert f"the observers read (of {recorded:,} recorded)" in out
