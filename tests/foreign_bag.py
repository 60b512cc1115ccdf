"""A ROS 1 recording of the pioneer robot written directly with rosbags, not by racc.

Its own motion, rates, jitter and a properties CSV sampled at 1 Hz on the bag's clock,
with five faults one after another (see :data:`FAULTS`), so that replay is tried on data
racc's synthesiser did not make.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

START = 1_700_000_000.0  # the bag's clock at the start of the recording
DURATION = 240.0
NODES = {  # node -> (cpu %, mem bytes) when healthy; limits in models/pioneer.ram
    "p2os": (4.0, 12e6),
    "sicklms": (3.0, 10e6),
    "xsens_driver": (5.0, 20e6),
    "joy_node": (0.5, 5e6),
    "teleop_joy": (0.5, 5e6),
    "slam_gmapping": (30.0, 100e6),
    "rviz": (15.0, 200e6),
}
# (what, target, start, end, the component a correct diagnosis names)
FAULTS = (
    ("stopped topic", "/scan", 40.0, 60.0, "sicklms"),
    ("5x rate", "/pose", 80.0, 100.0, "p2os"),
    ("diverging yaw", "/imu/data", 120.0, 140.0, "xsens_driver"),
    ("crashed node", "teleop_joy", 160.0, 180.0, "teleop_joy"),
    ("cpu overload", "slam_gmapping", 200.0, 220.0, "slam_gmapping"),
)


def _window(name: str) -> tuple[float, float]:
    for what, _, start, end, _ in FAULTS:
        if what == name:
            return start, end
    raise KeyError(name)


def _turn_rate(t: np.ndarray) -> np.ndarray:
    """Gentle S-curves: the robot turns left and right through the corridor."""
    rate: np.ndarray = 0.45 * np.sin(2 * math.pi * t / 23.0) + 0.2 * np.sin(2 * math.pi * t / 7.0)
    return rate


def _yaw(t: np.ndarray) -> np.ndarray:
    a, b = 23.0 / (2 * math.pi), 7.0 / (2 * math.pi)
    yaw: np.ndarray = -0.45 * a * np.cos(t / a) - 0.2 * b * np.cos(t / b) + 0.45 * a + 0.2 * b
    return yaw


def _times(
    rng: np.random.Generator,
    rate: float,
    gaps: tuple[float, float] | None = None,
    fast: tuple[float, float] | None = None,
) -> np.ndarray:
    """Message times at ``rate`` with 3 % jitter; none in ``gaps``; 5x as many in ``fast``."""
    out = []
    t = 0.02
    while t < DURATION:
        if gaps is None or not gaps[0] <= t < gaps[1]:
            out.append(t)
        step = 1.0 / rate
        if fast is not None and fast[0] <= t < fast[1]:
            step /= 5.0
        t += step * (1.0 + float(rng.normal(0.0, 0.03)))
    return np.asarray(out)


def _quaternion(store, yaw: float):  # type: ignore[no-untyped-def]
    quat = store.types["geometry_msgs/msg/Quaternion"]
    return quat(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _header(store, t: float, frame: str):  # type: ignore[no-untyped-def]
    header = store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    absolute = START + t
    sec = int(absolute)
    return header(seq=0, stamp=stamp(sec=sec, nanosec=int((absolute - sec) * 1e9)), frame_id=frame)


def write(bag: Path, csv: Path) -> None:
    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    rng = np.random.default_rng(11)
    vec3, point = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Point"]
    pose_t = _times(rng, 10.0, fast=_window("5x rate"))
    imu_t = _times(rng, 100.0)
    scan_t = _times(rng, 5.0, gaps=_window("stopped topic"))
    div_start, div_end = _window("diverging yaw")
    messages = []
    cov36 = np.zeros(36, dtype=np.float64)
    cov9 = np.zeros(9, dtype=np.float64)
    for t in pose_t.tolist():
        yaw = float(_yaw(np.array([t]))[0]) + float(rng.normal(0, 0.002))
        w = float(_turn_rate(np.array([t]))[0]) + float(rng.normal(0, 0.01))
        pose = T["geometry_msgs/msg/Pose"](
            position=point(x=0.3 * t, y=0.0, z=0.0), orientation=_quaternion(store, yaw)
        )
        twist = T["geometry_msgs/msg/Twist"](
            linear=vec3(x=0.3, y=0.0, z=0.0), angular=vec3(x=0.0, y=0.0, z=w)
        )
        msg = T["nav_msgs/msg/Odometry"](
            header=_header(store, t, "odom"),
            child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov36),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=cov36),
        )
        messages.append((t, "/pose", "nav_msgs/msg/Odometry", msg))
    for t in imu_t.tolist():
        yaw = float(_yaw(np.array([t]))[0]) + float(rng.normal(0, 0.002))
        if div_start <= t < div_end:
            yaw += 0.9 * (t - div_start)  # the IMU's heading runs away from the odometry's
        w = float(_turn_rate(np.array([t]))[0]) + float(rng.normal(0, 0.01))
        msg = T["sensor_msgs/msg/Imu"](
            header=_header(store, t, "imu"),
            orientation=_quaternion(store, yaw),
            orientation_covariance=cov9,
            angular_velocity=vec3(x=0.0, y=0.0, z=w),
            angular_velocity_covariance=cov9,
            linear_acceleration=vec3(x=float(rng.normal(0, 0.05)), y=0.0, z=9.81),
            linear_acceleration_covariance=cov9,
        )
        messages.append((t, "/imu/data", "sensor_msgs/msg/Imu", msg))
    for t in scan_t.tolist():
        ranges = (2.0 + rng.normal(0, 0.01, 36)).astype(np.float32)
        msg = T["sensor_msgs/msg/LaserScan"](
            header=_header(store, t, "laser"),
            angle_min=-1.57, angle_max=1.57, angle_increment=0.0872, time_increment=0.0,
            scan_time=0.2, range_min=0.1, range_max=30.0,
            ranges=ranges, intensities=np.zeros(0, dtype=np.float32),
        )  # fmt: skip
        messages.append((t, "/scan", "sensor_msgs/msg/LaserScan", msg))
    messages.sort(key=lambda m: m[0])
    publisher = {"/pose": "/p2os", "/imu/data": "/xsens_driver", "/scan": "/sicklms"}
    with Writer(bag) as writer:
        conns = {
            topic: writer.add_connection(
                topic, typename, typestore=store, callerid=publisher[topic]
            )
            for topic, typename in (
                ("/pose", "nav_msgs/msg/Odometry"),
                ("/imu/data", "sensor_msgs/msg/Imu"),
                ("/scan", "sensor_msgs/msg/LaserScan"),
            )
        }
        for t, topic, typename, msg in messages:
            stamp = round((START + t) * 1e9)
            writer.write(conns[topic], stamp, store.serialize_ros1(msg, typename))
    csv.write_text(_properties(rng), encoding="utf-8")


def _properties(rng: np.random.Generator) -> str:
    """1 Hz samples on the bag's clock; the crashed node leaves none, the overload shows."""
    crash = _window("crashed node")
    overload = _window("cpu overload")
    lines = ["time,node,cpu,mem"]
    for k in range(int(DURATION)):
        t = float(k) + 0.5
        for node, (cpu, mem) in NODES.items():
            if node == "teleop_joy" and crash[0] <= t < crash[1]:
                continue
            c = cpu * (1 + float(rng.normal(0, 0.05)))
            if node == "slam_gmapping" and overload[0] <= t < overload[1]:
                c = 150.0
            lines.append(f"{START + t:.3f},/{node},{c:.2f},{int(mem)}")
    return "\n".join(lines) + "\n"
