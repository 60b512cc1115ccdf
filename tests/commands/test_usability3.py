"""Issue 38: what a new user and a real configuration tripped over, third pass.  The
language's messages are goldens in tests/errors/, the wrong kinds of path are walked in
test_wrong_kind_of_path.py, the names in test_did_you_mean.py, the tug configuration's slips
in tests/test_tug_import.py, the runtime's graph in tests/runtime/test_runtime.py."""

from __future__ import annotations

from pathlib import Path

import pytest
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_learn_on_random_bytes_says_it_is_no_bag_not_a_codec_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = tmp_path / "random.bag"
    bag.write_bytes(bytes([0xCA, 0xFE, 0x00, 0x12]) * 1000)
    code, _, err = _run(["learn", str(bag), "-o", str(tmp_path / "x.ram")], capsys)
    assert code == 1
    assert "codec" not in err and "utf-8" not in err
    assert f"{bag}: is a binary file, not a recording" in err
    assert "a ROS 1 bag starts with '#ROSBAG V2.0'" in err


def test_a_ros1_bag_without_publishers_is_not_said_to_be_ros2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A ROS 1 bag whose connections carry no callerid (a converter wrote it)."""
    store = get_typestore(Stores.ROS1_NOETIC)
    bag = tmp_path / "converted.bag"
    with Writer(bag) as writer:
        conn = writer.add_connection("/value", "std_msgs/msg/Float64", typestore=store)
        msg = store.types["std_msgs/msg/Float64"]
        for i in range(100):
            raw = store.serialize_ros1(msg(data=float(i % 7)), "std_msgs/msg/Float64")
            writer.write(conn, 1_000_000_000 + i * 100_000_000, raw)
    code, _, err = _run(["learn", str(bag), "-o", str(tmp_path / "x.ram")], capsys)
    assert code == 0, err
    assert "ROS 2 bags do not record them" not in err
    assert "its ROS 1 connections carry no callerid" in err


def test_a_bag_with_a_damaged_header_says_so_in_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import struct

    field = b"\xca\xfe=ab"  # a header field whose name is not UTF-8
    header = struct.pack("<I", len(field)) + field
    bag = tmp_path / "damaged.bag"
    bag.write_bytes(b"#ROSBAG V2.0\n" + struct.pack("<I", len(header)) + header + b"\0" * 5000)
    code, _, err = _run(["learn", str(bag), "-o", str(tmp_path / "x.ram")], capsys)
    assert code == 1
    assert "codec" not in err
    assert f"{bag}: cannot read the recording: damaged: a name or text in it is not UTF-8" in err


def test_demo_help_says_roslaunch_starts_a_master(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "a running master" not in text
    assert "roslaunch starts a master when none answers at ROS_MASTER_URI" in text


def test_run_given_the_model_and_demo_given_the_build_say_what_to_pass(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`racc run models/tedusar.ram` said "cannot read the launch file: not well-formed";
    `racc demo build/tedusar` "is a directory, not a file"."""
    code, _, err = _run(["run", "--ros", "1", TEDUSAR], capsys)
    assert code == 1
    assert f"{TEDUSAR}: is a .ram model, not the directory racc compile wrote" in err
    assert f"compile it first: racc compile {TEDUSAR} -o build/tedusar, then racc run" in err
    build = tmp_path / "tedusar"
    assert main(["compile", TEDUSAR, "-o", str(build), "-q"]) == 0
    code, _, err = _run(["demo", str(build), "--write-only", "-o", str(tmp_path / "d")], capsys)
    assert code == 1
    assert f"{build}: is the directory racc compile wrote, not a model (a .ram" in err
    assert "give the .ram (or .json) it was compiled from" in err


def test_a_rate_learned_from_an_on_demand_topic_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The demo robot publishes /cmd_vel and /goal (no rate in its model) at a steady 2 Hz:
    `racc record` then `racc learn` gave them `@ 2 Hz` without a word."""
    store = get_typestore(Stores.ROS1_NOETIC)
    bag = tmp_path / "demo.bag"
    twist = store.types["geometry_msgs/msg/Twist"]
    vector = store.types["geometry_msgs/msg/Vector3"]
    floats = store.types["std_msgs/msg/Float64"]
    with Writer(bag) as writer:
        cmd = writer.add_connection(
            "/cmd_vel", "geometry_msgs/msg/Twist", typestore=store, callerid="/teleop"
        )
        goal = writer.add_connection(
            "/goal", "std_msgs/msg/Float64", typestore=store, callerid="/planner"
        )
        level = writer.add_connection(
            "/level", "std_msgs/msg/Float64", typestore=store, callerid="/gauge"
        )
        for i in range(120):
            t = 1_000_000_000 + i * 500_000_000  # 2 Hz, like the demo's event topics
            move = twist(linear=vector(x=0.1 * (i % 5), y=0.0, z=0.0), angular=vector(0, 0, 0))
            writer.write(cmd, t, store.serialize_ros1(move, "geometry_msgs/msg/Twist"))
            value = store.serialize_ros1(floats(data=float(i % 3)), "std_msgs/msg/Float64")
            writer.write(goal, t + 1000, value)
            writer.write(level, t + 2000, value)
    out = tmp_path / "learned.ram"
    code, _, err = _run(["learn", str(bag), "-o", str(out)], capsys)
    assert code == 0, err
    text = out.read_text(encoding="utf-8")
    assert "topic /cmd_vel: the rate is learned, but /cmd_vel looks published on demand " in err
    assert "(geometry_msgs/Twist: velocity commands)" in err
    assert "/goal looks published on demand (named goal: goals)" in err
    assert "/level looks" not in err
    assert "# the rate is learned, but /cmd_vel looks published on demand" in text
