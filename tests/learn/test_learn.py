"""racc learn: learning models from synthetic recordings of the models in models/."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pytest

from rac.cli import main
from rac.fmt import format_model
from rac.ir import Model
from rac.learn import LearnOptions, LearnResult, learn, observer_counts
from rac.learn.fields import FieldSelector
from rac.learn.limits import CPU_FLOOR, MEM_MARGIN
from rac.learn.recording import Recording
from rac.load.bags import read_recording
from rac.load.files import load_model
from rac.parse import parse_ram
from rac.pipeline import compile_model
from rac.synth import SynthOptions, plan_recording, write_recording

ROOT = Path(__file__).resolve().parents[2]
# Every robot model we ship; pioneer joins as soon as it exists.
MODELS = [name for name in ("tedusar", "pioneer") if (ROOT / "models" / f"{name}.ram").exists()]
DURATION = 60.0


@dataclass(frozen=True)
class Robot:
    """A model with the names of its odometry and IMU topics."""

    name: str
    model: Model

    def topic_of_type(self, msg_type: str) -> str:
        found = [t.name.value for t in self.model.topics if t.msg_type == msg_type]
        assert found, f"{self.name} has no {msg_type} topic"
        return found[0]

    @property
    def odometry(self) -> str:
        return self.topic_of_type("nav_msgs/Odometry")

    @property
    def imu(self) -> str:
        return self.topic_of_type("sensor_msgs/Imu")


def _robot(name: str) -> Robot:
    return Robot(name, load_model(ROOT / "models" / f"{name}.ram"))


def _record(
    robot: Robot, path: Path, seed: int, ros_version: int, storage: str = "sqlite3"
) -> Path:
    options = SynthOptions(DURATION, seed, ros_version, storage)
    plan = plan_recording(robot.model, options)
    write_recording(plan, path)
    path.with_name(path.name + ".properties.csv").write_text(plan.properties)
    return path


# Fields the yaw/pitch checks need, whether or not a model lists them.
SELECT = ("yaw", "pitch")


def _read(robot: Robot, *paths: Path) -> Recording:
    declared = {t.name.value: frozenset(f.value for f in t.fields) for t in robot.model.topics}
    return read_recording(list(paths), FieldSelector(declared, SELECT))


def _learn(robot: Robot, recording: Recording, **options: float) -> LearnResult:
    return learn(recording, LearnOptions(**options), base=robot.model)


@pytest.fixture(scope="module", params=MODELS)
def robot(request: pytest.FixtureRequest) -> Robot:
    return _robot(str(request.param))


@pytest.fixture(scope="module")
def ros1_run(robot: Robot, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _record(robot, tmp_path_factory.mktemp(robot.name) / "run.bag", 1, 1)


@pytest.fixture(scope="module")
def ros2_run(robot: Robot, tmp_path_factory: pytest.TempPathFactory) -> Path:
    # The same run as ros1_run (seed 1), written as a ROS 2 bag: the same model comes out.
    return _record(robot, tmp_path_factory.mktemp(f"{robot.name}-ros2") / "run", 1, 2)


@pytest.fixture(scope="module")
def ros1_recording(robot: Robot, ros1_run: Path) -> Recording:
    return _read(robot, ros1_run)


@pytest.fixture(scope="module")
def ros1_result(robot: Robot, ros1_recording: Recording) -> LearnResult:
    return _learn(robot, ros1_recording)


def _related(result: LearnResult) -> set[frozenset[str]]:
    return {frozenset((r.a.text, r.b.text)) for r in result.model.related}


def _check_learned(robot: Robot, result: LearnResult) -> None:
    """Rates within 2 %, irregular topics irregular, the yaw relation, no unrelated one."""
    learned = result.model.topic_by_name()
    for topic in robot.model.topics:
        got = learned[topic.name.value]
        if topic.rate_hz is None:
            assert got.rate_hz is None, topic.name.value
        else:
            assert got.rate_hz is not None and got.rate_tolerance_hz is not None
            assert got.rate_hz == pytest.approx(topic.rate_hz, rel=0.02), topic.name.value
            assert 0 < got.rate_tolerance_hz < got.rate_hz
    related = _related(result)
    assert frozenset((f"{robot.imu}.yaw", f"{robot.odometry}.yaw")) in related
    # The heading integrates the turn rate: only the integrated rate matches, declared I().
    turn = f"I({robot.odometry}.twist.twist.angular.z)"
    assert frozenset((turn, f"{robot.odometry}.yaw")) in related
    assert frozenset((turn[2:-1], f"{robot.odometry}.yaw")) not in related
    # Heading and ground slope are independent in the synthetic world.
    assert frozenset((f"{robot.imu}.pitch", f"{robot.odometry}.yaw")) not in related
    compile_model(result.model)


def test_learns_rates_and_the_yaw_relation_from_a_ros1_bag(
    robot: Robot, ros1_result: LearnResult
) -> None:
    _check_learned(robot, ros1_result)


def test_learns_the_same_from_a_ros2_bag(robot: Robot, ros2_run: Path) -> None:
    recording = _read(robot, ros2_run)
    assert recording.runs[0].ros_version == 2
    _check_learned(robot, _learn(robot, recording))


def test_learns_the_same_from_a_ros2_mcap_bag(tmp_path: Path) -> None:
    tedusar = _robot("tedusar")
    run = _record(tedusar, tmp_path / "mcap", 6, 2, "mcap")
    assert "storage_identifier: mcap" in (run / "metadata.yaml").read_text()
    _check_learned(tedusar, _learn(tedusar, _read(tedusar, run)))


@pytest.mark.slow
def test_learns_from_two_merged_runs(
    robot: Robot,
    ros1_run: Path,
    ros1_recording: Recording,
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    second = _record(robot, tmp_path_factory.mktemp(f"{robot.name}-b") / "second.bag", 2, 1)
    recording = _read(robot, ros1_run, second)
    first_alone = ros1_recording
    # Algorithm 19: the second run starts where the first ended.
    pose = recording.topic_by_name()[robot.odometry]
    assert set(pose.segments.tolist()) == {0, 1}
    span = recording.runs[0].end - recording.runs[0].start
    assert pose.times[pose.segments == 1][0] >= span - 1e-6
    assert pose.times[-1] == pytest.approx(2 * DURATION, abs=1.0)
    assert pose.count > first_alone.topic_by_name()[robot.odometry].count
    result = _learn(robot, recording)
    _check_learned(robot, result)
    assert result.model.comments[0].startswith("Learned by racc learn from 2 run(s)")


def test_fewer_relations_for_higher_q(robot: Robot, ros1_recording: Recording) -> None:
    recording = ros1_recording
    # The candidates are the meaningful pairs, whose trends agree most of the time the robot
    # moves (0.92 to 1.00 here): only a Q near 1 rejects some of them.
    counts = [
        observer_counts(_learn(robot, recording, q=q).model)["BiQObs"] for q in (0.5, 0.9, 0.95)
    ]
    assert counts[0] >= counts[1] >= counts[2]
    assert counts[0] > counts[2]


def test_base_relations_not_learned_again_are_named(
    robot: Robot, ros1_recording: Recording
) -> None:
    result = _learn(robot, ros1_recording, q=0.995)
    learned = _related(result)
    dropped = [
        f"{r.a.text} ~ {r.b.text}"
        for r in robot.model.related
        if frozenset((r.a.text, r.b.text)) not in learned
    ]
    assert dropped, "Q 0.995 should lose some of the base's relations"
    note = next(n for n in result.notes if n.startswith("relations of the base model"))
    assert all(d in note for d in dropped)


def test_fewer_frequency_observers_for_higher_alpha(
    robot: Robot, ros1_recording: Recording
) -> None:
    recording = ros1_recording
    counts = [
        observer_counts(_learn(robot, recording, alpha=a).model)["GObs"] for a in (0.5, 2.5, 10.0)
    ]
    assert counts[0] > counts[1] >= counts[2] > 0


def test_every_learned_value_has_its_evidence(ros1_result: LearnResult) -> None:
    model = ros1_result.model
    for topic in model.topics:
        assert any(c.startswith("learned from") for c in topic.comments), topic.name.value
    for rel in model.related:
        # What it means (its reading), its evidence, its held-out result.
        reading, evidence, held = rel.comments
        assert reading.split(":")[0] in ("graph", "semantic"), reading
        assert evidence.startswith("trend match ratio")
        assert held.startswith("held out on")
    text = format_model(model)
    assert parse_ram(text, "learned.ram") == model  # the written file reads back the same
    assert "# learned from" in text and "interval/σ" in text


def test_limits_from_the_properties_csv(
    robot: Robot, ros1_run: Path, ros1_recording: Recording
) -> None:
    from rac.learn.properties import parse_properties, property_stats

    csv_path = ros1_run.with_name(ros1_run.name + ".properties.csv")
    stats = property_stats(parse_properties(csv_path.read_text(), str(csv_path)))
    result = learn(ros1_recording, LearnOptions(), base=robot.model, properties=stats)
    nodes = result.model.node_by_name()
    for s in stats:
        limit = getattr(nodes[s.node].limits, s.prop)
        assert limit >= s.maximum
        # mean + 3σ rounded up, or the floor: 5 % cpu, 1.2 × the largest memory sample.
        floor = CPU_FLOOR if s.prop == "cpu" else MEM_MARGIN * s.maximum + 1000
        assert limit <= max(s.mean + 4 * s.stddev + 1000, floor)
    counts = observer_counts(result.model)
    assert counts["PObs_cpu"] == counts["PObs_mem"] == len(robot.model.nodes)


def test_without_base_a_ros1_bag_gives_publishers_and_says_what_is_missing(
    robot: Robot, ros1_run: Path
) -> None:
    recording = read_recording([ros1_run], FieldSelector())
    result = learn(recording, LearnOptions())
    publishers = result.model.publishers()
    for topic, nodes in robot.model.publishers().items():
        assert publishers[topic] == (nodes[0],)
    assert any("--base" in n for n in result.notes)
    assert not any(n.subscribes for n in result.model.nodes)
    compile_model(result.model)


def test_without_base_a_ros2_bag_has_no_nodes_and_keeps_the_evidence_in_comments(
    robot: Robot, ros2_run: Path
) -> None:
    result = learn(read_recording([ros2_run], FieldSelector()), LearnOptions())
    assert result.model.nodes == () and result.model.related == ()
    assert any("no publishers" in n for n in result.notes)
    assert any(robot.odometry in c for c in result.model.trailing_comments)
    compile_model(result.model)


GRAPH = """\
nodes:
  /jaguar_node:
    publications: ["/pose [nav_msgs/Odometry]", /rosout]
    subscriptions: ["* /cmd_vel [geometry_msgs/Twist]"]
    drives: [jaguar]
  /imu_node:
    publishers: [/imu_data]
  /joy_node:
    publishers: [/joy]
  /jaguar_teleop_node:
    subscribers: [/joy]
    publishers: [/cmd_vel]
hardware:
  jaguar: {switchable: true, channel: 1}
"""


def test_graph_gives_the_structure(tmp_path: Path) -> None:
    tedusar = _robot("tedusar")
    plan = plan_recording(tedusar.model, SynthOptions(30, 5, 2))
    run = tmp_path / "g"
    write_recording(plan, run)
    graph_file = tmp_path / "graph.yaml"
    graph_file.write_text(GRAPH)
    out = tmp_path / "learned.ram"
    args = ["learn", str(run), "--graph", str(graph_file), "-o", str(out), "--name", "jag"]
    assert main(args) == 0
    model = load_model(out)
    nodes = model.node_by_name()
    assert nodes["jaguar_node"].published_topics == ("/pose",)
    assert [s.value for s in nodes["jaguar_node"].subscribes] == ["/cmd_vel"]
    assert [a.value for a in nodes["jaguar_teleop_node"].publishes[0].affected_by] == ["/joy"]
    assert model.hardware_by_name()["jaguar"].switchable
    assert "/rosout" not in model.topic_by_name()
    assert model.topic_by_name()["/pose"].rate_hz == pytest.approx(10, rel=0.02)
    compile_model(model)


def test_bad_graph_is_an_input_error(tmp_path: Path, ros1_run: Path) -> None:
    graph_file = tmp_path / "graph.yaml"
    graph_file.write_text("nodes: [a, b]\n")
    args = ["learn", str(ros1_run), "--graph", str(graph_file), "-o", str(tmp_path / "x.ram")]
    assert main(args) == 1
    assert not (tmp_path / "x.ram").exists()


def test_cli_learns_and_reports_table_10_1_counts(
    robot: Robot, ros1_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, report = tmp_path / "learned.ram", tmp_path / "report.json"
    model_path = ROOT / "models" / f"{robot.name}.ram"
    csv_path = ros1_run.with_name(ros1_run.name + ".properties.csv")
    args = [
        "learn",
        str(ros1_run),
        "--base",
        str(model_path),
        "-o",
        str(out),
        "--properties",
        str(csv_path),
        "--report",
        str(report),
        "--include-fields",
        *SELECT,
    ]
    assert main(args) == 0
    doc = json.loads(report.read_text())
    learned = load_model(out)
    assert doc["observers"] == observer_counts(learned)
    assert doc["observers"]["GObs"] == sum(1 for t in robot.model.topics if t.regular)
    assert doc["runs"][0]["ros_version"] == 1
    assert "learned" in capsys.readouterr().out
    assert main(["check", str(out)]) == 0


@pytest.mark.parametrize(
    "bad",
    [
        ["-Q", "1.5"],
        ["--alpha", "0"],
        ["--occurrences", "1"],
        ["--alpha", "nan"],
        ["--alpha", "inf"],
        ["--sigmas", "nan"],
        ["--sigmas", "inf"],
        ["--min-lift", "nan"],
    ],
)
def test_cli_rejects_bad_parameters(bad: list[str], ros1_run: Path, tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["learn", str(ros1_run), "-o", str(tmp_path / "x.ram"), *bad])
    assert exit_.value.code == 2


def test_cli_reports_an_unreadable_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"not a bag")
    assert main(["learn", str(junk), "-o", str(tmp_path / "x.ram")]) == 1
    assert "RAC080" in capsys.readouterr().err
    assert main(["learn", str(tmp_path / "missing.bag"), "-o", str(tmp_path / "x.ram")]) == 1


def test_cli_reports_a_damaged_bag_without_a_traceback(
    ros1_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Bags whose index reads but whose chunks are damaged: rosbags raises its own
    ReaderError or fails an assert while the messages are read (seen on these patterns)."""
    original = ros1_run.read_bytes()
    assert len(original) > 200_000
    for start, step in ((50_000, 997), (5_000, 20_011), (5_000, 100_003)):
        data = bytearray(original)
        for i in range(start, len(data), step):
            data[i] ^= 0x5A
        damaged = tmp_path / f"damaged-{step}.bag"
        damaged.write_bytes(bytes(data))
        assert main(["learn", str(damaged), "-o", str(tmp_path / "x.ram")]) == 1, step
        assert "RAC080" in capsys.readouterr().err
        assert not (tmp_path / "x.ram").exists()
