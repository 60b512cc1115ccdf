"""racc synth: synthetic recordings are real bags with the model's timing and physics."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import cast

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Reader as Reader1

from rac.cli import main
from rac.errors import RacError
from rac.learn.fields import FieldSelector, euler_from_quaternion, quaternion_from_euler
from rac.learn.recording import Recording
from rac.load.bags import read_recording
from rac.load.files import load_model
from rac.synth import SynthOptions, plan_recording, write_recording
from rac.synth.faults import parse_fault

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"
DURATION = 60.0


def _synth(path: Path, **options: object) -> Path:
    model = load_model(TEDUSAR)
    given = cast("Iterable[str]", options.pop("faults", ()))  # _synth(..., faults=[...])
    faults = tuple(parse_fault(f, model) for f in given)
    plan = plan_recording(model, SynthOptions(duration=DURATION, faults=faults, **options))
    write_recording(plan, path)
    (path.parent / (path.name + ".csv")).write_text(plan.properties)
    return path


@pytest.fixture(scope="module")
def clean_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _synth(tmp_path_factory.mktemp("synth") / "clean.bag", seed=3)


@pytest.fixture(scope="module")
def faulty_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    faults = (
        "slip@30:/pose",
        "crash@40:joy_node",
        "freq@20+20:/scan",
        "cpu@10+10:imu_node",
        "mem@50:hector_mapping",
    )
    return _synth(tmp_path_factory.mktemp("synth") / "faulty.bag", seed=3, faults=faults)


def _all_fields(path: Path) -> Recording:
    return read_recording([path], FieldSelector(None, ("*",)))


def test_ros1_connections_name_the_publishing_node(clean_bag: Path) -> None:
    model = load_model(TEDUSAR)
    expected = {t: f"/{nodes[0]}" for t, nodes in model.publishers().items()}
    # The board's measurements, as racc's board client publishes them (devices on channels).
    expected["/board_measurements"] = "/racc_board_client"
    with Reader1(clean_bag) as reader:
        found = {c.topic: getattr(c.ext, "callerid", None) for c in reader.connections}
    assert found == expected


def test_messages_have_real_ros_types_and_embedded_definitions(clean_bag: Path) -> None:
    with AnyReader([clean_bag]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        assert types["/pose"] == "nav_msgs/msg/Odometry"
        assert types["/imu_data"] == "sensor_msgs/msg/Imu"
        assert types["/scan"] == "sensor_msgs/msg/LaserScan"
        assert types["/la_servo1_moving"] == "tedusar_msgs/msg/ServoState"
        conn = next(c for c in reader.connections if c.topic == "/la_servo1_moving")
        _, _, raw = next(reader.messages(connections=[conn]))
        servo = reader.deserialize(raw, conn.msgtype)
        assert {"angle", "pos_angle", "neg_angle"} <= set(vars(servo))


def test_regular_topics_tick_at_their_rate_and_events_are_irregular(clean_bag: Path) -> None:
    recording = _all_fields(clean_bag)
    model = load_model(TEDUSAR)
    for topic in model.topics:
        data = recording.topic_by_name()[topic.name.value]
        deltas = data.intervals()
        if topic.rate_hz is not None:
            assert 1 / deltas.mean() == pytest.approx(topic.rate_hz, rel=0.01)
            assert deltas.mean() / deltas.std() > 5
        else:
            assert deltas.mean() / deltas.std() < 2


def test_odometry_yaw_integrates_its_angular_velocity_and_the_imu_follows(clean_bag: Path) -> None:
    topics = _all_fields(clean_bag).topic_by_name()
    pose, imu = topics["/pose"], topics["/imu_data"]
    yaw = pose.values[pose.fields.index("yaw")]
    rate = pose.values[pose.fields.index("twist.twist.angular.z")]
    integrated = np.concatenate([[0.0], np.cumsum(rate[:-1] * np.diff(pose.times))])
    assert np.max(np.abs((yaw - yaw[0]) - integrated)) < 0.2
    assert np.ptp(yaw) > 1.0  # the robot does turn
    imu_yaw = np.interp(pose.times, imu.times, imu.values[imu.fields.index("yaw")])
    offset = imu_yaw - yaw
    assert np.ptp(offset) < 0.1


def test_servo_follows_the_imu_pitch(clean_bag: Path) -> None:
    topics = _all_fields(clean_bag).topic_by_name()
    imu, servo = topics["/imu_data"], topics["/la_servo1_moving"]
    pitch = np.interp(servo.times, imu.times, imu.values[imu.fields.index("pitch")])
    angle = servo.values[servo.fields.index("angle")]
    assert np.max(np.abs(pitch - angle)) < 0.05
    assert np.ptp(angle) > 0.05


@pytest.mark.slow
def test_faults_show_in_the_recording_and_the_properties(faulty_bag: Path) -> None:
    topics = _all_fields(faulty_bag).topic_by_name()
    pose, imu = topics["/pose"], topics["/imu_data"]
    imu_yaw = np.interp(pose.times, imu.times, imu.values[imu.fields.index("yaw")])
    gap = np.abs(imu_yaw - pose.values[pose.fields.index("yaw")])
    assert gap[pose.times < 29].max() < 0.1 and gap[-1] > 1.0  # slip from 30 s
    joy = topics["/joy"].times
    assert joy.max() < 40 <= joy.max() + 5  # crash at 40 s
    scan = topics["/scan"].times
    assert np.sum((scan >= 20) & (scan < 40)) == pytest.approx(5 * 40 * 20, rel=0.05)
    assert np.sum((scan >= 45) & (scan < 55)) == pytest.approx(40 * 10, rel=0.05)
    rows = [
        line.split(",") for line in (faulty_bag.parent / "faulty.bag.csv").read_text().split()[1:]
    ]
    cpu = [(float(t), float(c)) for t, n, c, _ in rows if n == "imu_node"]
    assert min(c for t, c in cpu if 10 <= t < 20) >= 25 > max(c for t, c in cpu if t < 10)
    mem = [(float(t), float(m)) for t, n, _, m in rows if n == "hector_mapping"]
    before = np.mean([m for t, m in mem if t < 50])
    # Doubled, and at least 1.5 times hector_mapping's 512 MB limit.
    limit = 512_000_000
    assert before == pytest.approx(limit / 2, rel=0.05)
    assert min(m for t, m in mem if t >= 50) >= 1.5 * limit
    assert not [r for r in rows if r[1] == "joy_node" and float(r[0]) >= 40]


def test_same_seed_same_plan_other_seed_other_plan() -> None:
    model = load_model(TEDUSAR)
    a = plan_recording(model, SynthOptions(duration=20, seed=5))
    b = plan_recording(model, SynthOptions(duration=20, seed=5))
    c = plan_recording(model, SynthOptions(duration=20, seed=6))
    assert a.properties == b.properties
    assert all(np.array_equal(x.times, y.times) for x, y in zip(a.topics, b.topics, strict=True))
    assert a.properties != c.properties


def test_quaternion_round_trip() -> None:
    angles = np.array([(0.3, -0.2, 0.1), (-2.5, 0.4, -0.3), (3.0, 0.0, 0.0)])
    quaternions = quaternion_from_euler(angles[:, 0], angles[:, 1], angles[:, 2])
    for k, (yaw, pitch, roll) in enumerate(angles.tolist()):
        back = euler_from_quaternion(*quaternions[:, k].tolist())
        assert back == pytest.approx((yaw, pitch, roll), abs=1e-9)


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [
        ("slip@10", "not of the form"),
        ("warp@10:/pose", "unknown kind"),
        ("crash@10:/pose", "no node"),
        ("freq@10:jaguar_node", "no topic"),
        ("slip@10:/scan", "odometry"),
    ],
)
def test_bad_fault_specs_are_input_errors(spec: str, fragment: str) -> None:
    with pytest.raises(RacError) as err:
        parse_fault(spec, load_model(TEDUSAR))
    assert err.value.diagnostics[0].code == "RAC083"
    assert fragment in err.value.diagnostics[0].message


def test_cli_writes_a_ros2_mcap_bag_and_properties_and_refuses_to_overwrite(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run2"
    args = ["synth", str(TEDUSAR), "-o", str(out), "--duration", "10", "--storage", "mcap"]
    assert main(args) == 0
    assert (out / "metadata.yaml").exists()
    assert "storage_identifier: mcap" in (out / "metadata.yaml").read_text()
    assert (tmp_path / "run2.properties.csv").read_text().startswith("time,node,cpu,mem\n")
    with AnyReader([out]) as reader:
        assert reader.message_count > 1000
    assert main(args) == 1
    assert "RAC084" in capsys.readouterr().err
    assert main([*args, "--force"]) == 0
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_cli_rejects_a_bad_fault(tmp_path: Path) -> None:
    out = str(tmp_path / "x.bag")
    with pytest.raises(SystemExit) as caught:  # malformed: the command line is wrong
        main(["synth", str(TEDUSAR), "-o", out, "--fault", "oops"])
    assert caught.value.code == 2
    # Well formed, but the model has no such node: the input is wrong.
    assert main(["synth", str(TEDUSAR), "-o", out, "--fault", "crash@3:no_such_node"]) == 1
    assert not (tmp_path / "x.bag").exists()


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        (["-o", "x.bag", "--duration", "nan"], "--duration"),
        (["-o", "x.bag", "--duration", "inf"], "--duration"),
        (["-o", "x.bag", "--duration", "1e9"], "--duration"),
        (["-o", "x.bag", "--seed", "-5"], "--seed"),
        (["-o", "x.bag", "--seed", "1000000"], "--seed"),
        (["-o", "x", "--ros1"], "ends in .bag"),  # learn could not read it back
        (["-o", "x.bag", "--ros2"], "directory"),
        (["-o", "x.bag", "--storage", "mcap"], "--storage is for ROS 2"),
    ],
)
def test_cli_rejects_bad_options_with_exit_2(
    options: list[str], fragment: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    options = [str(tmp_path / o) if o.startswith("x") else o for o in options]
    assert main(["synth", str(TEDUSAR), *options]) == 2
    assert fragment in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_staging_left_by_a_killed_synth_is_removed_at_the_next_run(tmp_path: Path) -> None:
    """A `racc synth` killed mid-run left its `.racc-synth-*` staging directory behind (38
    of 120 killed runs); the next run removes those of processes no longer running, and
    leaves a running one's alone."""
    import os
    import subprocess
    import sys

    finished = subprocess.Popen([sys.executable, "-c", "pass"])
    finished.wait()
    stale = tmp_path / f".racc-synth-{finished.pid}-k1ll3d"
    (stale / "run").mkdir(parents=True)
    (stale / "run" / "half.db3").write_bytes(b"\0" * 100)
    live = tmp_path / f".racc-synth-{os.getpid()}-busy"
    live.mkdir()
    model = str(Path(__file__).resolve().parents[2] / "models" / "tedusar.ram")
    assert main(["synth", model, "-o", str(tmp_path / "r.bag"), "--duration", "1", "-q"]) == 0
    assert not stale.exists()
    assert live.exists()
    assert (tmp_path / "r.bag").is_file()
