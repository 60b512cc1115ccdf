"""Replay judges to the end of the recording, and a ground truth outside it is an error
(issue 35, goal 6)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import small_bags

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
PIONEER = str(ROOT / "models" / "pioneer.ram")


@pytest.fixture(scope="module")
def stops_near_the_end(tmp_path_factory: pytest.TempPathFactory) -> Path:
    # /pose (10 Hz, the model's odometry) stops at 20 s; /extra, a topic the model does not
    # know, goes on to 30 s: the recording lasts 30 s.
    bag = tmp_path_factory.mktemp("span") / "run.bag"
    return small_bags.write(
        bag,
        [
            ("/pose", "nav_msgs/msg/Odometry", "/p2os", np.arange(0.0, 20.0, 0.1)),
            ("/extra", "std_msgs/msg/Float64", "/other", np.arange(0.0, 30.0, 0.1)),
        ],
    )


def test_a_topic_that_stops_near_the_end_is_judged(
    stops_near_the_end: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["replay", PIONEER, str(stops_near_the_end), "-q"]) == 0
    assert main(["replay", PIONEER, str(stops_near_the_end)]) == 0
    out = capsys.readouterr().out
    # Replayed to the recording's last message (29.9 s), not to /pose's last one (19.9 s).
    assert ", 29.9 s, through" in out
    assert "diagnosed [p2os]" in out and "not_ok(pose)" in out


def test_ground_truth_outside_the_replayed_span_is_an_error(
    stops_near_the_end: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    truth = tmp_path / "truth.yaml"
    truth.write_text(
        "faults:\n- {kind: crash, target: p2os, start: 20, end: 34, culprits: [p2os]}\n"
    )
    code = main(["replay", PIONEER, str(stops_near_the_end), "--truth", str(truth)])
    err = capsys.readouterr().err
    assert code == 1
    assert "RAC160" in err and "20-34 s ends outside the replayed span" in err
    assert "0-29.900 s" in err
    # Within the span it is scored, a fault lasting to the end ending with the recording.
    truth.write_text("faults:\n- {kind: crash, target: p2os, start: 20, culprits: [p2os]}\n")
    assert main(["replay", PIONEER, str(stops_near_the_end), "--truth", str(truth)]) == 0
    out = capsys.readouterr().out
    assert "fault crash p2os 20-29.9 s: reported at" in out
