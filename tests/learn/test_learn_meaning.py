"""Relations that mean something (issue 35): candidates from the graph and the message types,
true relations kept on a robot that rests, value faults detected and isolated."""

from __future__ import annotations

from collections.abc import Sequence

import pytest
import robot_runs
from robot_runs import IMU, ODOM

from rac.diagnosis.theory import theory_of
from rac.evaluate.score import score_run
from rac.ir import Model, Name, Node, Publication
from rac.learn.candidates import GRAPH, SEMANTIC, UNEXPLAINED, TopicInfo, candidates
from rac.learn.graph import parse_graph
from rac.learn.learner import LearnResult, learn
from rac.learn.options import LearnOptions
from rac.learn.recording import Recording, message_stream
from rac.pipeline import compile_model
from rac.replay.engine import replay
from rac.replay.timeline import Timeline
from rac.synth.truth import InjectedFault

GRAPH_YAML = """
nodes:
  /imu_node: {publications: [/imu/data]}
  /base_node: {publications: [/odom]}
"""


def _pairs(found: Sequence[object]) -> dict[frozenset[str], str]:
    return {
        frozenset((c.a.text, c.b.text)): c.reading.kind  # type: ignore[attr-defined]
        for c in found
    }


# -- candidates ----------------------------------------------------------------------------

IMU_INFO = TopicInfo(IMU, "sensor_msgs/Imu", robot_runs.IMU_FIELDS)
ODOM_INFO = TopicInfo(ODOM, "nav_msgs/Odometry", robot_runs.ODOM_FIELDS)
CMD_INFO = TopicInfo("/cmd_vel", "geometry_msgs/Twist", ("linear.x", "angular.z"))


def test_semantic_candidates_pair_one_quantity_measured_twice() -> None:
    found = _pairs(candidates([IMU_INFO, ODOM_INFO], [], {IMU, ODOM}, blind=False))
    # A heading from the IMU and from odometry; a turn rate from both; a turn rate against
    # the change of each heading (its own message's too).
    assert found[frozenset(("/imu/data.yaw", "/odom.yaw"))] == SEMANTIC
    assert (
        found[frozenset(("/imu/data.angular_velocity.z", "/odom.twist.twist.angular.z"))]
        == SEMANTIC
    )
    assert found[frozenset(("I(/imu/data.angular_velocity.z)", "/imu/data.yaw"))] == SEMANTIC
    assert found[frozenset(("I(/odom.twist.twist.angular.z)", "/imu/data.yaw"))] == SEMANTIC
    # Not: a rate against a linear acceleration, or anything against a position.
    assert (
        frozenset(("/imu/data.angular_velocity.z", "/imu/data.linear_acceleration.y")) not in found
    )
    assert len(found) == 6
    # Without a steady rate nothing is integrated.
    plain = _pairs(candidates([IMU_INFO, ODOM_INFO], [], set(), blind=False))
    assert not any("I(" in s for pair in plain for s in pair)


def test_graph_candidates_pair_a_nodes_input_with_its_output() -> None:
    base = Node(
        Name("base_node"),
        subscribes=(Name("/cmd_vel"),),
        publishes=(Publication(Name("/odom")),),
    )
    found = candidates([CMD_INFO, ODOM_INFO], [base], {ODOM}, blind=False)
    readings = {frozenset((c.a.text, c.b.text)): c.reading for c in found}
    command = readings[frozenset(("/cmd_vel.angular.z", "/odom.twist.twist.angular.z"))]
    assert command.kind == GRAPH and command.edge == ("base_node", "/cmd_vel", "/odom")
    assert "commanded against measured velocity" not in command.text  # it is a turn rate
    assert frozenset(("/cmd_vel.linear.x", "/odom.twist.twist.linear.x")) in readings
    assert (
        "commanded against measured"
        in readings[frozenset(("/cmd_vel.linear.x", "/odom.twist.twist.linear.x"))].text
    )


def _relays(n: int) -> tuple[list[TopicInfo], list[Node]]:
    """Two chains of n/2 topic_tools relays, one of the IMU and one of the odometry."""
    infos = [IMU_INFO, ODOM_INFO]
    nodes = []
    for source, info in ((IMU, IMU_INFO), (ODOM, ODOM_INFO)):
        previous = source
        for k in range(n // 2):
            topic = f"{source}_relay{k}"
            infos.append(TopicInfo(topic, info.msg_type, info.fields))
            nodes.append(
                Node(
                    Name(f"relay_{source.strip('/')}_{k}"),
                    subscribes=(Name(previous),),
                    publishes=(Publication(Name(topic)),),
                )
            )
            previous = topic
    return infos, nodes


def test_candidates_grow_with_the_edges_not_with_the_square_of_the_fields() -> None:
    counts = {}
    for n in (10, 20, 40):
        infos, nodes = _relays(n)
        found = candidates(infos, nodes, set(), blind=False)
        counts[n] = len(found)
        # Relayed copies are not measurements: no copy is paired with a copy of the other.
        assert not any(
            "relay" in c.a.topic and "relay" in c.b.topic and c.reading.kind != GRAPH for c in found
        )
        assert all(c.reading.kind in (GRAPH, SEMANTIC) for c in found)
    # Per relay the same fields of its input and output (4 or 3); plus the two sources'.
    assert counts[20] - counts[10] == 5 * 4 + 5 * 3
    assert counts[40] - counts[20] == 2 * (counts[20] - counts[10])
    blind = len(candidates(*_relays(20), set(), blind=True))
    assert blind > 10 * counts[20]


def test_blind_pairs_come_only_when_asked_or_when_nothing_else_applies() -> None:
    found = candidates([IMU_INFO, ODOM_INFO], [], set(), blind=True)
    kinds = {c.reading.kind for c in found}
    assert kinds == {SEMANTIC, UNEXPLAINED}
    alone = candidates([TopicInfo("/x", "my_msgs/X", ("a", "b"))], [], set(), blind=False)
    assert [c.reading.kind for c in alone] == [UNEXPLAINED]


# -- learning on a robot that rests --------------------------------------------------------


@pytest.fixture(scope="module")
def healthy() -> LearnResult:
    return learn(
        robot_runs.recording(1), LearnOptions(), graph=parse_graph(GRAPH_YAML, "graph.yaml")
    )


def _related(model: Model) -> set[frozenset[str]]:
    return {frozenset((r.a.text, r.b.text)) for r in model.related}


def test_a_true_heading_relation_is_kept_on_a_robot_that_rests(healthy: LearnResult) -> None:
    related = _related(healthy.model)
    # The IMU's heading wanders by ±0.05 rad while the robot stands still, beside flat
    # odometry: a trend observer that calls that noise a trend failed the relation.
    assert frozenset(("/imu/data.yaw", "/odom.yaw")) in related
    assert frozenset(("/imu/data.angular_velocity.z", "/odom.twist.twist.angular.z")) in related
    assert frozenset(("I(/imu/data.angular_velocity.z)", "/imu/data.yaw")) in related
    # Nothing meaningless: every relation has a reading, none is unexplained.
    for r in healthy.model.related:
        assert r.comments[0].startswith(("semantic:", "graph:")), r.comments
    assert not any("linear_acceleration" in s for pair in related for s in pair)
    assert all(j.candidate.reading.kind != UNEXPLAINED for j in healthy.judged)


def test_a_held_out_recording_of_the_healthy_robot_raises_no_episode(
    healthy: LearnResult,
) -> None:
    for seed in (2, 3):
        timeline = _replay(healthy.model, robot_runs.recording(seed))
        assert score_run(timeline, []).false_positives == (), seed


def _replay(model: Model, rec: Recording) -> Timeline:
    compiled = compile_model(model)
    origin = min(float(t.times[0]) for t in rec.topics)
    end = max(float(t.times[-1]) for t in rec.topics) - origin
    events = message_stream(rec.topics, origin)
    return replay(compiled.observers, theory_of(compiled), events, end)


def _turning(seed: int) -> float:
    """The start of a 20 s stretch in which the robot turns (seconds from its start), after
    the first 100 s, in which the relation observers learn their signals' noise."""
    _, rate, _ = robot_runs.motion(seed, 360.0)
    for k in range(5, 17):
        if abs(rate[int((k * 20 + 10) / 0.02)]) > 0.4:
            return k * 20.0
    raise AssertionError("the run never turns")


@pytest.mark.parametrize(
    ("topic", "field", "how", "culprit"),
    [
        (IMU, "yaw", "flip", "imu_node"),
        (IMU, "angular_velocity.z", "flip", "imu_node"),
        (ODOM, "yaw", "freeze", "base_node"),
        (ODOM, "yaw", "slip", "base_node"),
    ],
)
def test_value_faults_are_detected_and_isolated(
    healthy: LearnResult, topic: str, field: str, how: str, culprit: str
) -> None:
    # A sensor that keeps publishing at its rate but says the wrong thing.
    start = _turning(4)
    faulty = robot_runs.with_fault(robot_runs.recording(4), topic, field, start, start + 15, how)
    fault = InjectedFault(how, topic, start, start + 15, (culprit,))
    timeline = _replay(healthy.model, faulty)
    score = score_run(timeline, [fault])
    (outcome,) = score.outcomes
    assert outcome.reported, (topic, field, how)
    assert outcome.latency is not None and outcome.latency < 8
    assert outcome.isolated, outcome.diagnoses
    assert score.false_positives == ()
