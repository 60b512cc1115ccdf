"""Small ROS 1 bags written with rosbags for tests: odometry, IMU and plain numbers on named
topics, at given times (seconds from the bag's start), with a heading that turns."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

START = 1_700_000_000.0
STORE = get_typestore(Stores.ROS1_NOETIC)
T = STORE.types


def _header(t: float, frame: str) -> Any:
    absolute = START + t
    sec = int(absolute)
    stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int((absolute - sec) * 1e9))
    return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)


def heading(t: float) -> tuple[float, float]:
    """A robot that turns left and right: (yaw, turn rate)."""
    return 0.8 * math.sin(t / 4.0), 0.2 * math.cos(t / 4.0)


def odometry(t: float) -> Any:
    yaw, rate = heading(t)
    vec3, point = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Point"]
    quat = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
    cov = np.zeros(36, dtype=np.float64)
    pose = T["geometry_msgs/msg/Pose"](position=point(x=0.1 * t, y=0.0, z=0.0), orientation=quat)
    twist = T["geometry_msgs/msg/Twist"](
        linear=vec3(x=0.1, y=0.0, z=0.0), angular=vec3(x=0.0, y=0.0, z=rate)
    )
    return T["nav_msgs/msg/Odometry"](
        header=_header(t, "odom"),
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=cov),
    )


def imu(t: float) -> Any:
    yaw, rate = heading(t)
    vec3 = T["geometry_msgs/msg/Vector3"]
    quat = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
    cov = np.zeros(9, dtype=np.float64)
    return T["sensor_msgs/msg/Imu"](
        header=_header(t, "imu"),
        orientation=quat,
        orientation_covariance=cov,
        angular_velocity=vec3(x=0.0, y=0.0, z=rate),
        angular_velocity_covariance=cov,
        linear_acceleration=vec3(x=0.0, y=0.0, z=9.81),
        linear_acceleration_covariance=cov,
    )


def joints(t: float) -> Any:
    """Two joints swinging: positions the integrals of their velocities."""
    position = np.array([0.5 * math.sin(t / 3.0), 0.3 * math.sin(t / 5.0)])
    velocity = np.array([0.5 / 3.0 * math.cos(t / 3.0), 0.3 / 5.0 * math.cos(t / 5.0)])
    return T["sensor_msgs/msg/JointState"](
        header=_header(t, "base"),
        name=["a", "b"],
        position=position,
        velocity=velocity,
        effort=np.zeros(2),
    )


def number(t: float) -> Any:
    return T["std_msgs/msg/Float64"](data=math.sin(t))


KINDS = {
    "nav_msgs/msg/Odometry": odometry,
    "sensor_msgs/msg/Imu": imu,
    "std_msgs/msg/Float64": number,
    "sensor_msgs/msg/JointState": joints,
}


def write(path: Path, topics: Sequence[tuple[str, str, str, np.ndarray]]) -> Path:
    """A bag of ``(topic, type, callerid, times)``: each message made for its time."""
    messages = []
    with Writer(path) as writer:
        for topic, msgtype, caller, times in topics:
            conn = writer.add_connection(topic, msgtype, typestore=STORE, callerid=caller)
            make = KINDS[msgtype]
            messages += [(float(t), conn, msgtype, make(float(t))) for t in times]
        messages.sort(key=lambda m: m[0])
        for t, conn, msgtype, msg in messages:
            raw = STORE.serialize_ros1(msg, msgtype)
            writer.write(conn, int((START + t) * 1e9), raw)
    return path
