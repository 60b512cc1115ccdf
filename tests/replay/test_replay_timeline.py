"""The replay timeline, its episodes, and scoring against ground truth (pure functions)."""

from __future__ import annotations

import json

from rac.evaluate.score import NO_FAULT, score_run
from rac.replay.timeline import (
    DiagnosisRecord,
    ObservationRecord,
    Timeline,
    episodes,
    summary_lines,
    to_jsonl,
)
from rac.synth.truth import InjectedFault as Fault


def _timeline() -> Timeline:
    return Timeline(
        (
            ObservationRecord(0.5, "ok(pose)"),
            DiagnosisRecord(1.0, ()),
            ObservationRecord(12.5, "not_ok(pose)"),
            DiagnosisRecord(13.0, (("jaguar_node",), ("jaguar",))),
            ObservationRecord(20.2, "ok(pose)"),
            DiagnosisRecord(21.0, ()),
            ObservationRecord(40.0, "not_running(rviz)"),
            DiagnosisRecord(41.0, (("rviz",),)),
        ),
        50.0,
    )


def test_jsonl_is_exactly_the_documented_shape() -> None:
    lines = to_jsonl(_timeline()).splitlines()
    assert json.loads(lines[2]) == {"t": 12.5, "observation": "not_ok(pose)"}
    assert json.loads(lines[3]) == {"t": 13.0, "diagnoses": [["jaguar_node"], ["jaguar"]]}
    assert json.loads(lines[1]) == {"t": 1.0, "diagnoses": []}
    assert lines[2] == '{"t": 12.5, "observation": "not_ok(pose)"}'


def test_episodes_open_and_close_with_the_diagnoses() -> None:
    eps = episodes(_timeline().records)
    assert [(e.start, e.end) for e in eps] == [(13.0, 21.0), (41.0, None)]
    assert eps[0].diagnoses == (("jaguar_node",), ("jaguar",))
    # The negative observation held when the episode opened is listed.
    assert eps[0].observations == ("not_ok(pose)",)
    assert eps[1].observations == ("not_running(rviz)",)
    lines = summary_lines(_timeline())
    assert lines[0] == "episode 1: 13.0 s, diagnosed [jaguar_node] | [jaguar]; cleared at 21.0 s"
    assert "still open at the end" in lines[2]


def test_a_fault_is_reported_when_a_diagnosis_in_its_window_names_a_culprit() -> None:
    faults = [
        Fault("crash", "jaguar_node", 12.0, 20.0, ("jaguar_node",)),
        Fault("cpu", "hector_mapping", 25.0, 30.0, ("hector_mapping",)),
    ]
    score = score_run(_timeline(), faults, grace=5.0)
    first, second = score.outcomes
    assert first.reported and first.first == 13.0
    assert not second.reported  # nothing diagnosed between 25 and 35 s
    # rviz at 41 s names no culprit of a fault active then (±5 s): one false positive.
    assert len(score.false_positives) == 1
    assert score.false_positives[0].kind == NO_FAULT
    assert score.false_positives[0].episode.start == 41.0


def test_grace_lets_a_late_diagnosis_count_and_hides_nothing_else() -> None:
    late = [Fault("crash", "rviz", 30.0, 37.0, ("rviz",))]
    assert score_run(_timeline(), late, grace=5.0).outcomes[0].reported
    assert not score_run(_timeline(), late, grace=3.0).outcomes[0].reported
    # With grace 3 the fault's widened window (27-40 s) no longer reaches the rviz episode
    # at 41 s: both episodes are false positives with no fault active.
    fps = score_run(_timeline(), late, grace=3.0).false_positives
    assert [fp.kind for fp in fps] == [NO_FAULT, NO_FAULT]


def test_a_diagnosis_in_effect_before_the_fault_detects_nothing() -> None:
    # The jaguar episode (13-21 s) began before a fault that starts at 15 s: it was caused
    # by something else, so it neither detects the fault nor counts as explained.
    fault = Fault("slip", "/pose", 15.0, 18.0, ("jaguar",))
    score = score_run(_timeline(), [fault])
    assert not score.outcomes[0].reported and score.outcomes[0].first is None
    assert [fp.episode.start for fp in score.false_positives] == [13.0, 41.0]
    assert [fp.kind for fp in score.false_positives] == [NO_FAULT, NO_FAULT]


def test_one_false_episode_does_not_detect_three_faults() -> None:
    # A model of one node names it in every diagnosis: its false episode, open before the
    # faults, would have "reported" all three.
    timeline = Timeline((DiagnosisRecord(1.0, ()), DiagnosisRecord(5.0, (("imu_node",),))), 60.0)
    faults = [
        Fault(k, "imu_node", s, s + 5, ("imu_node",))
        for k, s in (("a", 10.0), ("b", 20.0), ("c", 30.0))
    ]
    score = score_run(timeline, faults)
    assert [o.reported for o in score.outcomes] == [False, False, False]
    assert len(score.false_positives) == 1


def test_a_new_diagnosis_during_an_open_episode_detects() -> None:
    # An episode open before the fault that changes when the fault begins: the diagnosis
    # that starts then names the culprit, and counts.
    timeline = Timeline(
        (
            DiagnosisRecord(5.0, (("rviz",),)),
            DiagnosisRecord(16.0, (("jaguar", "rviz"), ("jaguar_node", "rviz"))),
            DiagnosisRecord(18.0, (("jaguar", "rviz"),)),
            DiagnosisRecord(30.0, ()),
        ),
        40.0,
    )
    outcome = score_run(timeline, [Fault("power", "jaguar", 15.0, 25.0, ("jaguar",))]).outcomes[0]
    assert outcome.reported and outcome.first == 16.0 and outcome.latency == 1.0
    # Two candidates at 16 s, the culprit in every diagnosis from 18 s.
    assert outcome.candidates == 2
    assert outcome.isolated and outcome.isolated_at == 18.0


def test_isolation_needs_the_culprit_in_every_minimal_diagnosis() -> None:
    faults = [Fault("crash", "jaguar_node", 12.0, 20.0, ("jaguar_node",))]
    outcome = score_run(_timeline(), faults).outcomes[0]
    # [jaguar_node] | [jaguar]: detected, not isolated.
    assert outcome.reported and not outcome.isolated and outcome.candidates == 2


def test_false_episodes_per_hour_of_healthy_recording() -> None:
    faults = [Fault("crash", "jaguar_node", 12.0, 20.0, ("jaguar_node",))]
    score = score_run(_timeline(), faults, grace=5.0)
    # 50 s of recording, 12-25 s inside the fault's window: 37 s healthy; the rviz
    # episode from 41 s to the end (9 s) is false.
    assert score.healthy_s == 37.0
    assert score.false_s == 9.0
    assert len(score.false_positives) == 1
