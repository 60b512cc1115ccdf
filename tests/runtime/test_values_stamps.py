"""Header stamps read straight from a message's bytes (rac.learn.stamps), as the observer
host reads them: real ROS 1 bags of robots racc did not record, and ROS 2 CDR."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag1 import Reader
from rosbags.typesys import Stores, get_typestore

from rac.runtime.values import Readers

ROOT = Path(__file__).resolve().parents[2]


def shared_data(name: str) -> Path:
    """A real bag of ../shared/data (beside the project; /work/shared/data in a worktree)."""
    for folder in (ROOT.parent / "shared" / "data", Path("/work/shared/data")):
        if (folder / name).is_file():
            return folder / name
    pytest.skip(f"the real recordings (../shared/data/{name}) are not beside the project")


@pytest.mark.parametrize(
    ("bag", "topic", "fields"),
    [
        ("jackal_imu_odom.bag", "/imu/data", frozenset({"angular_velocity.z"})),
        ("jackal_imu_odom.bag", "/jackal_velocity_controller/odom", frozenset()),
        ("pr2_joint_states_roslib_header.bag", "joint_states", frozenset()),  # roslib/Header
    ],
)
def test_ros1_stamps_are_the_headers_stamps(bag: str, topic: str, fields: frozenset[str]) -> None:
    store = get_typestore(Stores.ROS1_NOETIC)
    readers = Readers({topic: fields})
    with Reader(shared_data(bag)) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        seen = 0
        for conn, _, raw in reader.messages(connections=conns):
            definition = conn.msgdef.data if hasattr(conn.msgdef, "data") else str(conn.msgdef)
            ros_type = conn.msgtype.replace("/msg/", "/")
            values, stamp = readers.read(topic, raw, lambda: (ros_type, definition))  # noqa: B023
            # rosbags types a message as object: its fields depend on its type
            message: Any = store.deserialize_ros1(raw, conn.msgtype)
            header = message.header.stamp
            assert stamp == pytest.approx(header.sec + header.nanosec * 1e-9, abs=1e-9)
            assert set(values) == set(fields)
            seen += 1
            if seen == 300:
                break
    assert seen == 300


def cdr_imu(sec: int, nanosec: int, little_endian: bool = True) -> bytes:
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    vector = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.5)
    imu = t["sensor_msgs/msg/Imu"](
        header=t["std_msgs/msg/Header"](
            stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id="imu"
        ),
        orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.zeros(9),
        angular_velocity=vector,
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=vector,
        linear_acceleration_covariance=np.zeros(9),
    )
    return bytes(store.serialize_cdr(imu, "sensor_msgs/msg/Imu", little_endian=little_endian))


@pytest.mark.parametrize("little_endian", [True, False])
def test_cdr_stamps(little_endian: bool) -> None:
    readers = Readers({"/imu": frozenset({"angular_velocity.z"})}, ros_version=2)
    describe = lambda: ("sensor_msgs/msg/Imu", "")  # noqa: E731
    raw = cdr_imu(1_700_000_123, 250_000_000, little_endian)
    values, stamp = readers.read("/imu", raw, describe)
    assert stamp == 1_700_000_123.25
    if little_endian:  # rosbags' reader of the values takes little-endian CDR only
        assert values == {"angular_velocity.z": 0.5}


def test_a_zero_stamp_or_a_type_without_header_gives_none() -> None:
    readers = Readers({"/imu": frozenset(), "/twist": frozenset()}, ros_version=2)
    assert readers.read("/imu", cdr_imu(0, 0), lambda: ("sensor_msgs/msg/Imu", "")) == ({}, None)
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    vector = t["geometry_msgs/msg/Vector3"](x=1.0, y=2.0, z=3.0)
    twist = t["geometry_msgs/msg/Twist"](linear=vector, angular=vector)
    raw = bytes(store.serialize_cdr(twist, "geometry_msgs/msg/Twist"))
    assert readers.read("/twist", raw, lambda: ("geometry_msgs/msg/Twist", "")) == ({}, None)
