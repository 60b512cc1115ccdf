"""Issue 11's learning points: a field-less base, constant signals, old ROS 1 headers,
rates rounded to their tolerance, a word on stderr when nothing is left to relate."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

from rac.cli import main
from rac.learn.rates import rounded_rate as _rounded_rate
from rac.load.files import load_model

ROOT = Path(__file__).resolve().parents[2]
PIONEER = ROOT / "models" / "pioneer.ram"
YAW = frozenset(("/imu/data.yaw", "/pose.yaw"))


def _racc(*argv: str) -> None:
    assert main(list(argv)) == 0, argv


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("pioneer") / "run.bag"
    _racc("synth", str(PIONEER), "-o", str(path), "--duration", "60", "-q")
    return path


def _fieldless_ram(tmp: Path) -> Path:
    """models/pioneer.ram without a single field list and without its relations."""
    text = PIONEER.read_text(encoding="utf-8")
    text = re.sub(r"(topic [^{\n]*?)\s*\{[^{}]*\}", r"\1", text)
    text = "\n".join(line for line in text.splitlines() if not line.startswith("relate"))
    path = tmp / "base.ram"
    path.write_text(text + "\n", encoding="utf-8")
    return path


def _fieldless_json(tmp: Path) -> Path:
    doc = json.loads(_export(PIONEER))
    for topic in doc["topics"]:
        topic["fields"] = []
    doc["related"] = []
    path = tmp / "base.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def _export(path: Path) -> str:
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        _racc("export", "--json", str(path))
    return out.getvalue()


@pytest.mark.slow
@pytest.mark.parametrize("make_base", [_fieldless_ram, _fieldless_json], ids=["ram", "json"])
def test_a_fieldless_base_still_finds_the_yaw_relation(
    make_base: object, run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = make_base(tmp_path)  # type: ignore[operator]
    assert all(not t.fields for t in load_model(base).topics)
    out = tmp_path / "learned.ram"
    _racc("learn", str(run), "--base", str(base), "-o", str(out), "-q")
    learned = load_model(out)
    related = {frozenset((r.a.text, r.b.text)) for r in learned.related}
    assert YAW in related, related
    # The base's structure is kept: its nodes, and its topics gain only the related fields.
    assert [n.name.value for n in learned.nodes] == [
        n.name.value for n in load_model(PIONEER).nodes
    ]
    capsys.readouterr()


def test_learned_field_lists_drop_constant_signals(run: Path, tmp_path: Path) -> None:
    out = tmp_path / "learned.ram"
    _racc("learn", str(run), "-o", str(out), "-q", "--no-validate")
    scan = load_model(out).topic_by_name()["/scan"]
    fields = {f.value for f in scan.fields}
    assert not fields & {"angle_min", "angle_max", "angle_increment", "range_min", "range_max"}


def test_learned_rates_are_rounded_to_their_tolerance(run: Path, tmp_path: Path) -> None:
    out = tmp_path / "learned.ram"
    _racc("learn", str(run), "--base", str(PIONEER), "-o", str(out), "-q")
    rates = re.findall(r"@ ([0-9.e+-]+) Hz \+- ([0-9.e+-]+) Hz", out.read_text())
    assert rates
    for rate, tolerance in rates:
        # No digit below a tenth of the tolerance's leading digit.
        step = 10.0 ** (np.floor(np.log10(float(tolerance))) - 1)
        assert abs(float(rate) / step - round(float(rate) / step)) < 1e-6, (rate, tolerance)
    assert _rounded_rate(9.99997, 0.144) == (10.0, 0.145)
    assert _rounded_rate(5.00022, 0.0728) == (5.0, 0.0731)
    rate, tolerance = _rounded_rate(12.3456, 0.02)
    assert rate == 12.346 and tolerance >= 0.02 + abs(12.3456 - 12.346) - 1e-12


def test_says_when_no_signal_is_left_to_relate(
    run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = tmp_path / "one.ram"
    base.write_text("robot r\ntopic /map { info.width }\nnode slam { publishes /map }\n")
    _racc("learn", str(run), "--base", str(base), "-o", str(tmp_path / "l.ram"))
    assert "no two varying numeric signals are left to relate" in capsys.readouterr().err


# The definition an old rosbag (robot_state_publisher's joint_states_indexed.bag) carries:
# `Header` defined as roslib/Header, so std_msgs/Header is nowhere in the bag.
OLD_JOINT_STATE = """Header header
string[] name
float64[] position
float64[] velocity
float64[] effort

================================================================================
MSG: roslib/Header
uint32 seq
time stamp
string frame_id
"""


def test_old_roslib_header_bags_are_decoded_with_noetic_types(tmp_path: Path) -> None:
    store = get_typestore(Stores.ROS1_NOETIC)
    joint_state = store.types["sensor_msgs/msg/JointState"]
    header = store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    md5 = store.generate_msgdef("sensor_msgs/msg/JointState")[1]
    bag = tmp_path / "joint_states_indexed.bag"
    with Writer(bag) as writer:
        conn = writer.add_connection(
            "/joint_states",
            "sensor_msgs/msg/JointState",
            msgdef=OLD_JOINT_STATE,
            md5sum=md5,
            callerid="/robot",
        )
        for i in range(200):
            t = 1_000_000_000 + i * 10_000_000
            msg = joint_state(
                header(i, stamp(t // 10**9, t % 10**9), "base"),
                ["a"],
                np.array([np.sin(i / 10)]),
                np.zeros(1),
                np.zeros(1),
            )
            writer.write(conn, t, store.serialize_ros1(msg, "sensor_msgs/msg/JointState"))
    out = tmp_path / "learned.ram"
    _racc("learn", str(bag), "-o", str(out), "-q", "--include-fields", "position")
    topic = load_model(out).topic_by_name()["/joint_states"]
    assert topic.rate_hz == 100.0
    assert [f.value for f in topic.fields] == ["position"]
