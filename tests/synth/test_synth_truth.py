"""racc synth's ground truth: RUN.faults.yaml, --schedule thesis, and reading the file back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rac.cli import main
from rac.errors import RacError
from rac.load.faults import load_truth
from rac.load.files import load_model
from rac.parse import parse_ram
from rac.synth import SynthOptions, plan_recording
from rac.synth.faults import Fault, parse_fault
from rac.synth.schedule import (
    MAX_FAULT_S,
    MIN_FAULT_S,
    MIN_GAP_S,
    ORDER,
    WARMUP_S,
    TooShort,
    minimum_duration,
    thesis_schedule,
    thesis_targets,
)
from rac.synth.truth import (
    GroundTruth,
    InjectedFault,
    check_truth,
    dump_truth,
    ground_truth,
    parse_truth,
    truth_path,
)

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"
PIONEER = ROOT / "models" / "pioneer.ram"


def test_faults_file_beside_ros1_and_ros2_recordings() -> None:
    assert truth_path(Path("out/run.bag")) == Path("out/run.faults.yaml")
    assert truth_path(Path("out/run2")) == Path("out/run2.faults.yaml")


def test_cli_writes_the_faults_of_explicit_faults(tmp_path: Path) -> None:
    out = tmp_path / "run.bag"
    args = ["synth", str(PIONEER), "-o", str(out), "--duration", "20", "-q"]
    faults = ["--fault", "freq@12+3:/pose", "--fault", "crash@5:teleop_joy"]
    assert main([*args, *faults]) == 0
    assert (tmp_path / "run.faults.yaml").read_text() == (
        "# Faults injected by racc synth into run.bag, seconds from the start of the "
        "recording.\n"
        "robot: pioneer\n"
        "duration: 20.0\n"
        "faults:\n"
        "- kind: crash\n"
        "  target: teleop_joy\n"
        "  start: 5.0\n"
        "  end: 20.0\n"  # to the end of the recording
        "  culprits: [teleop_joy]\n"
        "- kind: freq\n"
        "  target: /pose\n"
        "  start: 12.0\n"
        "  end: 15.0\n"
        "  culprits: [p2os]\n"
    )
    truth = load_truth(tmp_path / "run.faults.yaml")
    assert [(f.kind, f.start, f.end) for f in truth.faults] == [
        ("crash", 5.0, 20.0),
        ("freq", 12.0, 15.0),
    ]


def test_cli_fault_free_run_and_ros2_directory(tmp_path: Path) -> None:
    out = tmp_path / "clean"
    assert main(["synth", str(TEDUSAR), "-o", str(out), "--duration", "5", "-q"]) == 0
    text = (tmp_path / "clean.faults.yaml").read_text()
    assert text.endswith("robot: tedusar\nduration: 5.0\nfaults: []\n")
    assert load_truth(tmp_path / "clean.faults.yaml") == GroundTruth("tedusar", 5.0, ())


def test_an_existing_faults_file_stops_everything(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "run.faults.yaml").write_text("mine\n")
    args = ["synth", str(TEDUSAR), "-o", str(tmp_path / "run.bag"), "--duration", "5"]
    assert main(args) == 1
    assert "RAC084" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.faults.yaml"]
    assert (tmp_path / "run.faults.yaml").read_text() == "mine\n"
    assert main([*args, "--force", "-q"]) == 0
    assert load_truth(tmp_path / "run.faults.yaml").faults == ()


def test_culprits_of_topic_faults_are_all_publishers_sorted() -> None:
    model = parse_ram(
        """robot r
        topic /odom : nav_msgs/Odometry { yaw } @ 10 Hz
        node zeta { publishes /odom }
        node alpha { publishes /odom }
        node beta { limits mem 8 MB }
        """
    )
    faults = (Fault("slip", 3.0, 2.0, "/odom"), Fault("mem", 1.0, None, "beta"))
    truth = ground_truth(model, 10.0, faults)
    assert truth.faults == (
        InjectedFault("mem", "beta", 1.0, 10.0, ("beta",)),
        InjectedFault("slip", "/odom", 3.0, 5.0, ("alpha", "zeta")),
    )


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [
        ("freq@10:/joy", "regular topic"),  # no rate: five times nothing is nothing
        ("slip@10+0:/pose", "D must be above 0"),
        ("crash@60:joy_node", "after the end of the recording"),
    ],
)
def test_faults_the_recording_would_not_show_are_refused(spec: str, fragment: str) -> None:
    with pytest.raises(RacError) as err:
        parse_fault(spec, load_model(TEDUSAR), duration=60.0)
    assert err.value.diagnostics[0].code == "RAC083"
    assert fragment in err.value.diagnostics[0].message


# --- the thesis schedule ---------------------------------------------------------------


EXPECTED_TARGETS = {
    PIONEER: {
        "slip": "/pose",
        "cpu": "p2os",
        "mem": "slam_gmapping",
        "freq": "/pose",
        "crash": "teleop_joy",
    },
    TEDUSAR: {
        "slip": "/pose",
        "cpu": "jaguar_node",
        "mem": "hector_mapping",
        "freq": "/pose",
        "crash": "jaguar_teleop_node",
    },
}
EXPECTED_CULPRITS = {PIONEER: "p2os", TEDUSAR: "jaguar_node"}


@pytest.mark.parametrize("path", [PIONEER, TEDUSAR], ids=["pioneer", "tedusar"])
@pytest.mark.parametrize("duration", [240.0, 241.7, 600.0, 3600.0])
def test_thesis_schedule_is_complete_sequential_and_spread(path: Path, duration: float) -> None:
    model = load_model(path)
    schedule = thesis_schedule(model, duration)
    assert schedule.notes == ()
    assert [f.kind for f in schedule.faults] == list(ORDER)
    assert {f.kind: f.target for f in schedule.faults} == EXPECTED_TARGETS[path]
    assert schedule.faults[0].start == WARMUP_S
    ends = [f.end for f in schedule.faults]
    for f in schedule.faults:
        assert f.duration is not None and MIN_FAULT_S <= f.duration <= MAX_FAULT_S
        assert round(f.start * 10) == f.start * 10  # tenths of a second
    for before, after in zip(schedule.faults, schedule.faults[1:], strict=False):
        assert after.start - before.end >= MIN_GAP_S - 1e-9
    assert duration - ends[-1] >= MIN_GAP_S - 1e-9  # the last fault recovers too
    truth = ground_truth(model, duration, schedule.faults)
    culprits = {f.kind: f.culprits for f in truth.faults}
    odometry_publisher = EXPECTED_CULPRITS[path]
    assert culprits["slip"] == culprits["freq"] == culprits["cpu"] == (odometry_publisher,)
    assert culprits["mem"] == (EXPECTED_TARGETS[path]["mem"],)
    assert culprits["crash"] == (EXPECTED_TARGETS[path]["crash"],)


def test_thesis_schedule_too_short_names_the_minimum(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(TooShort) as err:
        thesis_schedule(load_model(PIONEER), 239.9)
    assert err.value.minimum == minimum_duration(6) == 240.0
    out = str(tmp_path / "never.bag")
    assert main(["synth", str(PIONEER), "-o", out, "--schedule", "thesis"]) == 2  # 120 s
    assert "--duration 240 or more" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_thesis_targets_follow_the_documented_rules() -> None:
    model = parse_ram(
        """robot r
        hardware base
        hardware arm
        topic /odom_b : nav_msgs/Odometry { yaw } @ 10 Hz
        topic /odom_a : nav_msgs/Odometry { yaw } @ 10 Hz
        topic /imu : sensor_msgs/Imu { yaw } @ 50 Hz
        topic /cmd : geometry_msgs/Twist { linear.x }
        topic /plan : geometry_msgs/Twist { linear.x }
        node wheels_b drives base { subscribes /cmd publishes /odom_b limits mem 10 MB }
        node wheels_a { publishes /odom_a limits mem 30 MB }
        node imu_node drives arm { publishes /imu limits mem 30 MB }
        node planner { publishes /plan }
        node viewer { subscribes /plan }
        node teleop { publishes /cmd }
        relate /odom_b.yaw ~ /imu.yaw
        """
    )
    chosen, notes = thesis_targets(model)
    assert notes == ()
    # /odom_b is related (/odom_a is first by name only); imu_node and wheels_a tie on memory
    # (imu_node by name); teleop feeds a hardware driver, planner only a software node.
    assert dict(chosen) == {
        "slip": "/odom_b",
        "cpu": "wheels_b",
        "mem": "imu_node",
        "freq": "/odom_b",
        "crash": "teleop",
    }


def test_kinds_without_a_target_are_skipped_with_a_note(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bare.ram"
    path.write_text(
        """robot bare
        hardware cam
        topic /image : sensor_msgs/Image { height } @ 5 Hz
        node camera drives cam { publishes /image limits mem 64 MB }
        node viewer { subscribes /image }
        """
    )
    model = load_model(path)
    schedule = thesis_schedule(model, 100.0)
    assert [(f.kind, f.target) for f in schedule.faults] == [("mem", "camera"), ("freq", "/image")]
    assert [n.split(":")[0] for n in schedule.notes] == [
        "slip skipped",
        "cpu skipped",
        "crash skipped",
    ]
    out = tmp_path / "bare.bag"
    assert (
        main(["synth", str(path), "-o", str(out), "--duration", "100", "--schedule", "thesis"]) == 0
    )
    err = capsys.readouterr().err
    assert "note: --schedule thesis: slip skipped: no published odometry topic" in err
    assert [f.kind for f in load_truth(tmp_path / "bare.faults.yaml").faults] == ["mem", "freq"]


@pytest.mark.slow
def test_schedule_combines_with_explicit_faults(tmp_path: Path) -> None:
    out = tmp_path / "both.bag"
    args = ["synth", str(TEDUSAR), "-o", str(out), "--duration", "240", "-q"]
    assert main([*args, "--schedule", "thesis", "--fault", "cpu@100+5:imu_node"]) == 0
    truth = load_truth(tmp_path / "both.faults.yaml")
    assert len(truth.faults) == 7
    assert [f.start for f in truth.faults] == sorted(f.start for f in truth.faults)
    assert InjectedFault("cpu", "imu_node", 100.0, 105.0, ("imu_node",)) in truth.faults


def test_a_crash_with_a_duration_ends(tmp_path: Path) -> None:
    model = load_model(TEDUSAR)
    crash = (parse_fault("crash@10+5:joy_node", model, 30.0),)
    plan = plan_recording(model, SynthOptions(duration=30.0, faults=crash))
    times = {t.name: t.times for t in plan.topics}
    for topic in ("/joy", "/cmd_vel"):  # /cmd_vel is computed from /joy: it stops and resumes
        during = times[topic][(times[topic] >= 10) & (times[topic] < 15)]
        assert during.size == 0
        assert np.sum(times[topic] >= 15) > 10 and np.sum(times[topic] < 10) > 10
    rows = [line.split(",") for line in plan.properties.split()[1:]]
    joy = np.array([float(r[0]) for r in rows if r[1] == "joy_node"])
    assert not np.any((joy >= 10) & (joy < 15))
    assert np.sum(joy >= 15) == 30  # 15 s at 2 Hz: every sample is back
    assert np.sum(joy < 10) == 20


# --- reading and writing the file --------------------------------------------------------


def test_round_trip_through_load_truth(tmp_path: Path) -> None:
    model = load_model(PIONEER)
    truth = ground_truth(model, 600.0, thesis_schedule(model, 600.0).faults)
    path = tmp_path / "t.faults.yaml"
    path.write_text(dump_truth(truth, "t.bag"))
    assert load_truth(path) == truth
    assert check_truth(load_truth(path), [model]) == []
    odd = GroundTruth(
        "yes",
        12.345678,
        (
            InjectedFault("no", "1.5", 0.0, 1e-5, ("[x]", "a: b", "null", "~", "é")),
            InjectedFault("freq", "/a/b_c", 2.5, 12.345678, ("n-1",)),
        ),
    )
    assert parse_truth(dump_truth(odd, "odd\nname"), "odd") == odd


def test_a_hand_written_file(tmp_path: Path) -> None:
    path = tmp_path / "real.faults.yaml"
    path.write_text(
        """# my real run: I unplugged the Hokuyo at 40 s and crashed the teleop at 90 s
robot: tedusar
duration: 120
faults:
  - {kind: power, target: hokuyo, start: 40, end: 55.5, culprits: hokuyo}
  - kind: crash
    target: jaguar_teleop_node
    start: 90
    culprits: [jaguar_teleop_node, jaguar_teleop_node]
"""
    )
    truth = load_truth(path)
    assert truth == GroundTruth(
        "tedusar",
        120.0,
        (
            InjectedFault("power", "hokuyo", 40.0, 55.5, ("hokuyo",)),
            InjectedFault("crash", "jaguar_teleop_node", 90.0, 120.0, ("jaguar_teleop_node",)),
        ),
    )
    assert [f.kind for f in truth.active(45.0)] == ["power"]
    assert truth.active(55.5) == ()
    assert check_truth(truth, [load_model(TEDUSAR)]) == []
    wrong = check_truth(truth, [load_model(PIONEER)])
    assert [(d.code, d.is_error) for d in wrong] == [
        ("RAC107", False),
        ("RAC086", True),
        ("RAC086", True),
    ]
    assert "for robot 'tedusar', not 'pioneer'" in wrong[0].message
    assert wrong[1].span is not None and (wrong[1].span.line, wrong[1].span.column) == (5, 5)
    assert "culprit 'hokuyo' of the power fault is not in 'pioneer'" in wrong[1].message
    # several models: a culprit is wrong only when none of them has it; no robot check
    both = check_truth(truth, [load_model(PIONEER), load_model(TEDUSAR)], robot=False)
    assert both == []


GOOD_HEAD = "robot: r\nduration: 60.0\nfaults:\n"
GOOD_FAULT = "- kind: crash\n  target: n\n  start: 1.0\n  end: 2.0\n  culprits: [n]\n"


@pytest.mark.parametrize(
    ("text", "code", "line", "column", "fragment"),
    [
        ("robot: [r\n", "RAC085", 2, 1, "not valid YAML"),
        ("", "RAC085", 1, 1, "empty faults file"),
        ("- 1\n", "RAC085", 1, 1, "must be a mapping"),
        ("robot: r\nduration: 60\n", "RAC085", 1, 1, "lacks 'faults'"),
        (GOOD_HEAD + GOOD_FAULT + "extra: 1\n", "RAC085", 9, 1, "unknown key 'extra'"),
        ("robot: r\nrobot: s\nduration: 1\nfaults: []\n", "RAC085", 2, 1, "twice"),
        ("robot: r\nduration: soon\nfaults: []\n", "RAC085", 2, 11, "number of seconds"),
        ("robot: r\nduration: '60'\nfaults: []\n", "RAC085", 2, 11, "number of seconds"),
        ("robot: r\nduration: 0\nfaults: []\n", "RAC086", 2, 11, "above 0"),
        ("robot: 12\nduration: 1\nfaults: []\n", "RAC085", 1, 8, "'robot' must be a name"),
        (GOOD_HEAD.replace("faults:\n", "faults: 3\n"), "RAC085", 3, 9, "must be a list"),
        (GOOD_HEAD + "- crash\n", "RAC085", 4, 3, "a fault must be a mapping"),
        (GOOD_HEAD + GOOD_FAULT.replace("end:", "ende:"), "RAC085", 7, 3, "did you mean 'end'"),
        (GOOD_HEAD + GOOD_FAULT.replace("  culprits: [n]\n", ""), "RAC085", 4, 3, "'culprits'"),
        (GOOD_HEAD + GOOD_FAULT.replace("[n]", "[]"), "RAC085", 8, 13, "at least one"),
        (GOOD_HEAD + GOOD_FAULT.replace("[n]", "[n, 3]"), "RAC085", 8, 17, "must be a name"),
        (GOOD_HEAD + GOOD_FAULT.replace("end: 2.0", "end: 0.5"), "RAC086", 7, 8, "ends (0.5 s)"),
        (GOOD_HEAD + GOOD_FAULT.replace("end: 2.0", "end: 61"), "RAC086", 7, 8, "after the"),
        (GOOD_HEAD + GOOD_FAULT.replace("start: 1.0", "start: -1"), "RAC086", 6, 10, "before"),
        (GOOD_HEAD + GOOD_FAULT.replace("kind: crash", "kind:"), "RAC085", 4, 8, "'kind'"),
    ],
)
def test_malformed_files_give_located_errors(
    text: str, code: str, line: int, column: int, fragment: str, tmp_path: Path
) -> None:
    path = tmp_path / "bad.faults.yaml"
    path.write_text(text)
    with pytest.raises(RacError) as err:
        load_truth(path)
    first = err.value.diagnostics[0]
    assert first.code == code
    assert fragment in f"{first.message} {first.hint}"
    assert first.span is not None
    assert (first.span.file, first.span.line, first.span.column) == (str(path), line, column)


def test_every_problem_is_reported_at_once() -> None:
    text = (
        GOOD_HEAD + GOOD_FAULT.replace("start: 1.0", "start: x") + GOOD_FAULT.replace("[n]", "[]")
    )
    with pytest.raises(RacError) as err:
        parse_truth(text, "f.yaml")
    assert [(d.code, d.span.line if d.span else 0) for d in err.value.diagnostics] == [
        ("RAC085", 6),
        ("RAC085", 13),
    ]


def test_an_unreadable_file_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(RacError) as err:
        load_truth(tmp_path / "missing.faults.yaml")
    assert err.value.diagnostics[0].code == "RAC085"
    assert "no such file" in err.value.diagnostics[0].message


def test_the_documented_examples_load() -> None:
    doc = (ROOT / "docs" / "learning.md").read_text()
    section = doc.split("### Ground truth", 1)[1].split("\n## ", 1)[0]
    blocks = [b.split("```", 1)[0] for b in section.split("```yaml\n")[1:]]
    assert len(blocks) == 2
    model = load_model(PIONEER)
    synthetic = parse_truth(blocks[0], "doc")
    assert (
        synthetic.faults[0]
        == ground_truth(model, 600.0, thesis_schedule(model, 600.0).faults).faults[0]
    )
    written = parse_truth(blocks[1], "doc")
    assert [f.end for f in written.faults] == [55.5, 120.0]
    assert check_truth(written, [load_model(TEDUSAR)]) == []
