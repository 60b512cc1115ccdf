"""What racc learn takes: topics outside --graph and --exclude left out, several recordings
summarised on their own and merged, in parallel or not (issue 35, goals 5 and 8)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import robot_runs
import small_bags

from rac.cli import main
from rac.fmt import format_model
from rac.learn.graph import parse_graph
from rac.learn.learner import learn, rate_summary
from rac.learn.options import LearnOptions
from rac.learn.recording import merge_runs
from rac.learn.summary import summarize_relations
from rac.learn.trends import Signal
from rac.load.files import load_model
from rac.parallel import mapper

GRAPH = """
nodes:
  /imu_node: {publications: [/imu/data]}
  /base_node: {publications: [/odom]}
"""


@pytest.fixture(scope="module")
def two_imus(tmp_path_factory: pytest.TempPathFactory) -> Path:
    # /imu/data and /imu_data both mangle to imu_data; only the first is the robot's.
    d = tmp_path_factory.mktemp("imus")
    times = np.arange(0.0, 150.0, 0.02)
    small_bags.write(
        d / "run.bag",
        [
            ("/imu/data", "sensor_msgs/msg/Imu", "/imu_node", times),
            ("/imu_data", "sensor_msgs/msg/Imu", "/old_imu", times + 0.005),
            ("/odom", "nav_msgs/msg/Odometry", "/base_node", times + 0.01),
        ],
    )
    (d / "graph.yaml").write_text(GRAPH)
    return d


def test_topics_outside_the_graph_are_left_out_without_a_collision(
    two_imus: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = two_imus / "learned.ram"
    argv = ["learn", str(two_imus / "run.bag"), "--graph", str(two_imus / "graph.yaml")]
    assert main([*argv, "-o", str(out)]) == 0, capsys.readouterr().err
    err = capsys.readouterr().err
    assert "recorded topics not in the --graph, left out: /imu_data" in err
    topics = {t.name.value for t in load_model(out).topics}
    assert topics == {"/imu/data", "/odom"}


def test_exclude_takes_topic_globs(two_imus: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = two_imus / "excluded.ram"
    argv = ["learn", str(two_imus / "run.bag"), "--exclude", "/imu_*", "/nothing*", "-o", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    assert "topics left out by --exclude: /imu_data" in capsys.readouterr().err
    assert {t.name.value for t in load_model(out).topics} == {"/imu/data", "/odom"}


def test_the_report_gives_each_relation_its_reading_evidence_and_held_out_result(
    two_imus: Path,
) -> None:
    report = two_imus / "report.json"
    argv = ["learn", str(two_imus / "run.bag"), "--graph", str(two_imus / "graph.yaml")]
    assert main([*argv, "-o", str(two_imus / "r.ram"), "--report", str(report), "-q"]) == 0
    doc = json.loads(report.read_text())
    assert doc["related"], doc["notes"]
    for rel in doc["related"]:
        assert rel["reading"] in ("graph", "semantic", "unexplained")
        assert rel["meaning"] and rel["declared"].startswith("relate ")
        assert rel["variants"][0]["effective_checks"] > 0
        assert rel["held_out"] and "p" in rel["held_out"][0]
    assert {c["reading"] for c in doc["candidates"]} <= {"graph", "semantic", "unexplained"}
    assert doc["stability"] == {"splits": 2, "changed": doc["stability"]["changed"]}
    assert {t["clock"] for t in doc["topics"]} == {"header stamps"}


def test_statistics_of_recordings_summarised_apart_merge_into_those_of_both() -> None:
    runs = [robot_runs.run(1, 120.0), robot_runs.run(2, 120.0, start=5000.0)]
    both = merge_runs(runs)
    pairs = [
        (Signal(robot_runs.IMU, "yaw", False), Signal(robot_runs.ODOM, "yaw", False)),
        (
            Signal(robot_runs.IMU, "angular_velocity.z", True),
            Signal(robot_runs.IMU, "yaw", False),
        ),
    ]
    apart = [summarize_relations(both, i, pairs, 4, 10) for i in range(2)]
    merged = apart[0].merged(apart[1])
    assert merged.runs == ("robot1.bag", "robot2.bag")
    assert [len(s) for s in merged.splits] == [8, 10]  # 4 and 5 blocks per run
    for pair in pairs:
        first = apart[0].evidence(0, pair) + apart[1].evidence(0, pair)
        assert merged.evidence(0, pair) == first
        assert merged.quadrants[pair].inside.sum() == sum(
            a.quadrants[pair].inside.sum() for a in apart
        )
    rates = rate_summary(both, LearnOptions(), ())
    imu = rates.topics[robot_runs.IMU]
    assert len(imu.blocks) == 8 and imu.stamped is False


def test_learning_on_several_processes_learns_the_same_model() -> None:
    runs = [robot_runs.run(s, 120.0, start=1000.0 + 1000 * s) for s in (1, 2, 3)]
    recording = merge_runs(runs)
    graph = parse_graph(GRAPH.replace("/odom]", "/odom]"), "g.yaml")
    serial = learn(recording, LearnOptions(), graph=graph)
    spread = learn(recording, LearnOptions(), graph=graph, mapper=mapper(2))
    assert format_model(spread.model) == format_model(serial.model)
    assert serial.model.related


def test_a_joint_position_is_related_to_its_integrated_velocity_and_replayed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # JointState's arrays, included: their means, whose relation the derivative keeps.
    bag = small_bags.write(
        tmp_path / "arm.bag",
        [("/joint_states", "sensor_msgs/msg/JointState", "/arm", np.arange(0.0, 200.0, 0.02))],
    )
    out = tmp_path / "arm.ram"
    argv = ["learn", str(bag), "-o", str(out), "--include-fields", "position", "velocity"]
    assert main([*argv, "-q"]) == 0, capsys.readouterr().err
    related = {
        frozenset((r.a.text, r.b.text)): r.comments[0].strip() for r in load_model(out).related
    }
    pair = frozenset(("I(/joint_states.velocity)", "/joint_states.position"))
    assert related[pair] == "semantic: joint position against the integral of its velocity"
    # Replay reads the declared arrays as learning read them: no "has no position" note.
    assert main(["replay", str(out), str(bag)]) == 0
    captured = capsys.readouterr()
    assert "has no" not in captured.err and "no fault diagnosed" in captured.out
