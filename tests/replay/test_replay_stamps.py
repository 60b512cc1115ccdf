"""Replay feeds header stamps from the bag, and the frequency observers read real
recordings of robots racc did not record as healthy: a Clearpath Jackal's IMU and
odometry (about 50 Hz) and a PR2's joint states (100 Hz, an old roslib/Header)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from rac.cli import main
from rac.load.files import load_model
from rac.observe import Message, ObserverBank
from rac.pipeline import compile_model
from rac.replay.sources import Needs, load_run

ROOT = Path(__file__).resolve().parents[2]
JACKAL = """robot jackal
topic /imu/data : sensor_msgs/Imu { angular_velocity.z } @ 50 Hz
topic /jackal_velocity_controller/odom : nav_msgs/Odometry { twist.twist.angular.z } @ 50 Hz
node imu_node {
  publishes /imu/data
}
node controller {
  publishes /jackal_velocity_controller/odom
}
"""
PR2 = """robot pr2
topic joint_states : sensor_msgs/JointState @ 100 Hz
node player {
  publishes joint_states
}
"""


def shared_data(name: str) -> Path:
    """A real bag of ../shared/data (beside the project; /work/shared/data in a worktree)."""
    for folder in (ROOT.parent / "shared" / "data", Path("/work/shared/data")):
        if (folder / name).is_file():
            return folder / name
    pytest.skip(f"the real recordings (../shared/data/{name}) are not beside the project")


@pytest.mark.slow
@pytest.mark.parametrize(
    ("text", "bag", "atoms"),
    [
        (JACKAL, "jackal_imu_odom.bag", {"ok(imu_data)", "ok(jackal_velocity_controller_odom)"}),
        (PR2, "pr2_joint_states_roslib_header.bag", {"ok(joint_states)"}),
    ],
)
def test_a_healthy_real_recording_reads_ok_throughout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, bag: str, atoms: set[str]
) -> None:
    model = tmp_path / "robot.ram"
    model.write_text(text)
    out = tmp_path / "timeline.jsonl"
    assert main(["replay", str(model), str(shared_data(bag)), "-o", str(out)]) == 0
    assert "no fault diagnosed" in capsys.readouterr().out
    observations = [line for line in out.read_text().splitlines() if "observation" in line]
    assert {line.split('"')[-2] for line in observations} == atoms  # each once, positive


def jackal_events(tmp_path: Path) -> tuple[ObserverBank, list[Message]]:
    model = tmp_path / "jackal.ram"
    model.write_text(JACKAL)
    specs = compile_model(load_model(model)).observers
    bank = ObserverBank(specs)
    needs = Needs(bank.topic_fields(), frozenset(), False)
    events = load_run(str(shared_data("jackal_imu_odom.bag")), needs, None).events
    return bank, [e for e in events if isinstance(e, Message)]


def test_replay_carries_the_bags_header_stamps(tmp_path: Path) -> None:
    _, messages = jackal_events(tmp_path)
    assert len(messages) == 6121 and all(m.stamp is not None for m in messages)
    imu = [m for m in messages if m.topic == "/imu/data"]
    # The stamps are the simulator's clock (about 47 s at the start), not the recording's.
    assert imu[0].stamp == pytest.approx(47.58) and imu[0].t == pytest.approx(0.0, abs=0.01)


def late(messages: list[Message], amplitude: float, period: float, start: float) -> list[Message]:
    """The same messages, from ``start`` on received late by a lag that swings between 0
    and ``amplitude`` (a starved receiver falling behind and catching up)."""

    def lag(t: float) -> float:
        return amplitude * (1 - math.cos(2 * math.pi * max(t - start, 0.0) / period)) / 2

    out = [Message(m.t + lag(m.t), m.topic, m.values, m.stamp) for m in messages]
    return sorted(out, key=lambda m: m.t)


def observe(bank: ObserverBank, messages: list[Message]) -> list[str]:
    out = []
    tick = 0.1
    for m in messages:
        while tick <= m.t:
            out += bank.advance(tick)
            tick = round(tick + 0.1, 9)
        out += bank.feed(m)
    return [str(v) for v in out]


def test_the_bags_stamps_keep_a_late_receiver_from_crying_wolf(tmp_path: Path) -> None:
    # The Jackal's messages as a receiver that, after ten good seconds, falls behind by up to
    # 0.45 s every 4 s gets them: with the bag's stamps both topics read ok; by receive
    # time alone they do not.
    bank, messages = jackal_events(tmp_path)
    lagging = late(messages, 0.45, 4.0, start=10.0)
    assert observe(bank, lagging) == ["ok(imu_data)", "ok(jackal_velocity_controller_odom)"]
    unstamped = [Message(m.t, m.topic, m.values) for m in lagging]
    bank, _ = jackal_events(tmp_path)
    assert "not_ok(imu_data)" in observe(bank, unstamped)
