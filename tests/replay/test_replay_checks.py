"""Replay says what it could not check, reads the board, and sees short crashes (issue 23)."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from test_replay import read_timeline

from rac.cli import main
from rac.evaluate.score import score_run
from rac.load.faults import load_truth
from rac.observe.events import ChannelState, NodeSample
from rac.replay.sources import LIVENESS_SLACK, LIVENESS_STEP_S, Needs, liveness, load_run

ROOT = Path(__file__).resolve().parents[2]
PIONEER = str(ROOT / "models" / "pioneer.ram")


def _samples(
    node: str, start: float, end: float, period: float = 0.5
) -> list[tuple[float, str, float, float]]:
    out: list[tuple[float, str, float, float]] = []
    t = start
    while t < end:
        out.append((round(t, 6), node, 1.0, 1e6))
        t += period
    return out


def test_a_node_gets_no_liveness_before_its_first_sample() -> None:
    rows = sorted(_samples("a", 0.0, 20.0) + _samples("late", 10.0, 20.0), key=lambda r: r[0])
    events = liveness(rows, frozenset({"a", "late", "never"}))
    late = [e for e in events if e.node == "late"]
    assert late and min(e.t for e in late) == pytest.approx(10.0)
    assert all(e.running for e in late)
    assert not [e for e in events if e.node == "never"]


def test_a_vanished_node_reads_not_running_from_the_round_that_missed_it() -> None:
    # "a" and "b" are sampled in the same rounds (as racc record and racc synth write
    # them): the round at 10 s has a row of "a" but none of "b", so the sampler looked and
    # found no process.  That is definite: not running from 10 s, with no slack.
    rows = sorted(
        _samples("a", 0.0, 20.0) + _samples("b", 0.0, 10.0) + _samples("b", 13.0, 20.0),
        key=lambda r: r[0],
    )
    events: list[NodeSample] = [e for e in liveness(rows, frozenset({"b"})) if e.node == "b"]
    steps = sorted({round(y.t - x.t, 6) for x, y in itertools.pairwise(events)})
    assert steps == [LIVENESS_STEP_S]
    down = [e.t for e in events if not e.running]
    assert down[0] == pytest.approx(10.0, abs=1e-6)
    assert down[-1] < 13.0


def test_a_node_sampled_alone_keeps_the_slack() -> None:
    # No rounds (no other node shares its sample times): a missing sample is known only
    # once 1.5 periods have passed without one.
    rows = _samples("b", 0.0, 10.0) + _samples("b", 13.0, 20.0)
    events = [e for e in liveness(rows, frozenset({"b"})) if e.node == "b"]
    down = [e.t for e in events if not e.running]
    assert down[0] == pytest.approx(9.5 + 0.8, abs=1e-6)  # past 9.5 + 1.5 * 0.5
    assert down[0] > 9.5 + LIVENESS_SLACK * 0.5


def test_one_missing_row_does_not_make_a_node_not_running(tmp_path: Path) -> None:
    # A sampler that missed a node once (a psutil hiccup) gives θ = 5 failing checks at
    # most: the node observer stays positive.
    rows = sorted(
        _samples("a", 0.0, 20.0) + [r for r in _samples("b", 0.0, 20.0) if r[0] != 10.0],
        key=lambda r: r[0],
    )
    events = [e for e in liveness(rows, frozenset({"b"})) if e.node == "b"]
    assert sum(1 for e in events if not e.running) == 5


def test_a_three_second_crash_is_diagnosed_in_replay(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "crash.bag"
    args = ["synth", PIONEER, "-o", str(run), "--duration", "60", "--seed", "3", "-q"]
    assert main([*args, "--fault", "crash@30+3:teleop_joy"]) == 0
    out = tmp_path / "t.jsonl"
    assert main(["replay", PIONEER, str(run), "-o", str(out), "-q"]) == 0
    truth = load_truth(tmp_path / "crash.faults.yaml")
    assert truth.duration is not None
    score = score_run(read_timeline(out, truth.duration), truth.faults)
    (outcome,) = score.outcomes
    assert outcome.reported and outcome.first is not None
    # Live racc reports it 0.6 s after the process vanishes; replay as fast: the sampler's
    # round at 30 s finds no process, θ + 1 checks 0.1 s apart, and a changed Θ is
    # diagnosed at once (not at the next whole second).
    assert outcome.first - 30.0 <= 0.6
    assert score.false_positives == ()


def test_replay_notes_absent_topics_and_foreign_nodes(tmp_path: Path) -> None:
    run = tmp_path / "run.bag"
    assert main(["synth", PIONEER, "-o", str(run), "--duration", "20", "-q"]) == 0
    csv = tmp_path / "run.properties.csv"
    csv.write_text(csv.read_text() + "1.0,stranger,1.0,1000\n")
    needs = Needs(
        {"/pose": frozenset({"yaw"}), "/gps/fix": frozenset({"latitude"})},
        frozenset({"p2os", "ghost"}),
        False,
    )
    inputs = load_run(str(run), needs, str(csv))
    notes = " | ".join(inputs.notes)
    assert "not in the recording, so not checked: /gps/fix" in notes
    (stray,) = [n for n in inputs.notes if "samples of nodes the model lacks" in n]
    assert "stranger" in stray and "p2os" not in stray
    assert "no samples of ghost" in notes


def test_board_measurements_feed_the_hardware_observers(tmp_path: Path) -> None:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    array = store.types["diagnostic_msgs/msg/DiagnosticArray"]
    status = store.types["diagnostic_msgs/msg/DiagnosticStatus"]
    header = store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    kv = store.types["diagnostic_msgs/msg/KeyValue"]
    start = 1_600_000_000
    bag = tmp_path / "board.bag"
    with Writer(bag) as writer:
        conn = writer.add_connection(
            "/board_measurements", array.__msgtype__, typestore=store, callerid="/racc_board"
        )
        pose = writer.add_connection(
            "/pose", "std_msgs/msg/Float64", typestore=store, callerid="/p2os"
        )
        for i in range(10):
            on = "0" if i >= 5 else "1"
            msg = array(
                header(0, stamp(start + i, 0), ""),
                [status(0, "channel 2", "on" if on == "1" else "off", "hokuyo", [kv("on", on)])],
            )
            t = (start + i) * 10**9
            writer.write(conn, t, store.serialize_ros1(msg, array.__msgtype__))
            value = store.types["std_msgs/msg/Float64"](float(i))
            writer.write(pose, t, store.serialize_ros1(value, "std_msgs/msg/Float64"))
    needs = Needs({"/pose": frozenset({"data"})}, frozenset(), False, True)
    inputs = load_run(str(bag), needs, None)
    states = [e for e in inputs.events if isinstance(e, ChannelState)]
    assert [(s.channel, s.on) for s in states] == [(2, True)] * 5 + [(2, False)] * 5
    assert states[5].t == pytest.approx(5.0)


@pytest.mark.slow
def test_a_synth_trip_is_replayed_and_blamed_on_its_device(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tedusar = str(ROOT / "models" / "tedusar.ram")
    run = tmp_path / "trip.bag"
    args = ["synth", tedusar, "-o", str(run), "--duration", "40", "--seed", "2", "-q"]
    assert main([*args, "--fault", "trip@20+5:hokuyo"]) == 0
    truth = load_truth(tmp_path / "trip.faults.yaml")
    assert [(f.kind, f.culprits) for f in truth.faults] == [("trip", ("hokuyo",))]
    out = tmp_path / "t.jsonl"
    assert main(["replay", tedusar, str(run), "-o", str(out), "-q"]) == 0
    assert truth.duration is not None
    timeline = read_timeline(out, truth.duration)
    assert any(
        r.literal == "not_on(hokuyo)" and 19.9 <= r.t < 25
        for r in timeline.records
        if hasattr(r, "literal")
    )
    score = score_run(timeline, truth.faults)
    assert all(o.reported for o in score.outcomes) and score.false_positives == ()
    assert main([*args[:3], str(tmp_path / "x.bag"), "--fault", "trip@5:imu"]) == 1
    assert "no switchable device on a board channel 'imu'" in capsys.readouterr().err
