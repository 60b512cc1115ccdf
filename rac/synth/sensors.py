"""What each synthetic topic carries: the values of its fields at its publication times.

A topic's role follows from its message type (odometry, IMU, laser scan, joystick,
velocity command, map), or from its name for laser-alignment servos (``*servo*`` topics
with an ``angle``: the first follows the IMU's pitch, the next its roll).  Every other
topic carries smooth random signals of its own, unrelated to the motion and to each other.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from rac.ir import Topic
from rac.learn.fields import FloatArray
from rac.synth.world import MAX_SPEED, MAX_TURN, World

ArrayAt = Callable[[int], npt.NDArray[np.generic]]
SCAN_BEAMS = 181
MAP_RESOLUTION = 0.25  # m per cell: keeps the synthetic map small
SERVO_LAG_S = 0.1


@dataclass(slots=True)
class Content:
    """Per-message field values of one topic (index i is the i-th publication)."""

    scalars: dict[str, FloatArray] = field(default_factory=dict)
    arrays: dict[str, ArrayAt] = field(default_factory=dict)
    orientation: tuple[str, FloatArray, FloatArray, FloatArray] | None = (
        None  # path, yaw, pitch, roll
    )
    frame_id: str = "base_link"


def role_of(topic: Topic) -> str:
    kind = (topic.msg_type or "").replace("/msg/", "/")
    roles = {
        "nav_msgs/Odometry": "odometry",
        "sensor_msgs/Imu": "imu",
        "sensor_msgs/LaserScan": "scan",
        "sensor_msgs/Joy": "joy",
        "geometry_msgs/Twist": "command",
        "nav_msgs/OccupancyGrid": "map",
    }
    if kind in roles:
        return roles[kind]
    if "servo" in topic.name.value and any(f.value == "angle" for f in topic.fields):
        return "servo"
    return "random"


def _noise(rng: np.random.Generator, n: int, sigma: float) -> FloatArray:
    out: FloatArray = rng.normal(0.0, sigma, n)
    return out


def _smooth_random(rng: np.random.Generator, times: FloatArray) -> FloatArray:
    """A sum of slow sinusoids with random periods, phases and amplitudes, plus noise."""
    out = np.zeros_like(times)
    for _ in range(4):
        period = float(rng.uniform(5.0, 60.0))
        out += float(rng.uniform(0.2, 1.0)) * np.sin(
            2 * np.pi * times / period + rng.uniform(0, 6.3)
        )
    return out + _noise(rng, times.size, 0.02) + float(rng.uniform(-5, 5))


def _lagged(world: World, name: str, times: FloatArray, lag: float) -> FloatArray:
    return world.at(name, np.maximum(times - lag, 0.0))


@dataclass(frozen=True, slots=True)
class Source:
    """What a role's values are made from: the topic, its publication times, the simulated
    world, the run's random generator (drawn from in a fixed order: same seed, same bag),
    which laser-alignment servo this is, and the topic's leaf fields."""

    topic: Topic
    times: FloatArray
    world: World
    rng: np.random.Generator
    servo_index: int
    leaves: dict[str, str]

    @property
    def n(self) -> int:
        return int(self.times.size)


def _odometry(c: Content, s: Source) -> None:
    world, times, rng, n = s.world, s.times, s.rng, s.n
    yaw = world.at("yaw_odom", times)
    # Odometry integrates the wheels: smooth pose, slightly noisy velocities.
    c.scalars["pose.pose.position.x"] = world.at("x_odom", times)
    c.scalars["pose.pose.position.y"] = world.at("y_odom", times)
    c.scalars["twist.twist.linear.x"] = world.at("v", times) + _noise(rng, n, 0.005)
    c.scalars["twist.twist.angular.z"] = world.at("w_odom", times) + _noise(rng, n, 0.005)
    c.orientation = ("pose.pose.orientation", yaw, np.zeros(n), np.zeros(n))
    c.frame_id = "odom"


def _imu(c: Content, s: Source) -> None:
    world, times, rng, n = s.world, s.times, s.rng, s.n
    # The IMU's orientation comes out of its filter: a slow drift, little white noise;
    # its gyro is raw and noisy.
    drift = 0.01 * np.sin(2 * np.pi * times / 97.0 + float(rng.uniform(0, 6.3)))
    yaw = world.at("yaw", times) + drift + _noise(rng, n, 0.0005)
    pitch = world.at("pitch", times) + _noise(rng, n, 0.0005)
    roll = world.at("roll", times) + _noise(rng, n, 0.0005)
    c.orientation = ("orientation", yaw, pitch, roll)
    c.scalars["angular_velocity.z"] = world.at("w", times) + _noise(rng, n, 0.02)
    c.scalars["angular_velocity.x"] = _noise(rng, n, 0.02)
    c.scalars["angular_velocity.y"] = _noise(rng, n, 0.02)
    c.scalars["linear_acceleration.x"] = _noise(rng, n, 0.05)
    c.scalars["linear_acceleration.y"] = _noise(rng, n, 0.05)
    c.scalars["linear_acceleration.z"] = 9.81 + _noise(rng, n, 0.05)
    c.frame_id = "imu_link"


def _scan(c: Content, s: Source) -> None:
    rng, n = s.rng, s.n
    angles = np.linspace(-np.pi / 2, np.pi / 2, SCAN_BEAMS)
    x = s.world.at("x", s.times)

    def ranges(i: int) -> npt.NDArray[np.generic]:
        base = 4.0 + 2.0 * np.cos(2 * angles + 0.3 * x[i])
        out: npt.NDArray[np.generic] = (base + rng.normal(0.0, 0.01, SCAN_BEAMS)).astype(np.float32)
        return out

    c.arrays["ranges"] = ranges
    c.arrays["intensities"] = lambda i: np.zeros(0, dtype=np.float32)
    const = {
        "angle_min": -np.pi / 2,
        "angle_max": np.pi / 2,
        "angle_increment": np.pi / (SCAN_BEAMS - 1),
        "range_min": 0.1,
        "range_max": 30.0,
        "scan_time": 0.025,
    }
    c.scalars.update({k: np.full(n, v) for k, v in const.items()})
    c.frame_id = "laser"


def _joy(c: Content, s: Source) -> None:
    turn = s.world.at("w_cmd", s.times) / MAX_TURN
    speed = s.world.at("v_cmd", s.times) / MAX_SPEED
    c.arrays["axes"] = lambda i: np.array([turn[i], speed[i], 0.0, 0.0], dtype=np.float32)
    c.arrays["buttons"] = lambda i: np.array(
        [int(abs(speed[i]) + abs(turn[i]) > 0)] + [0] * 7, dtype=np.int32
    )


def _command(c: Content, s: Source) -> None:
    c.scalars["linear.x"] = s.world.at("v_cmd", s.times)
    c.scalars["angular.z"] = s.world.at("w_cmd", s.times)


def _map(c: Content, s: Source) -> None:
    x, y = s.world.at("x", s.times), s.world.at("y", s.times)
    span_x = np.maximum.accumulate(np.abs(x))
    span_y = np.maximum.accumulate(np.abs(y))
    width = (32 + 2 * span_x / MAP_RESOLUTION).astype(int)
    height = (32 + 2 * span_y / MAP_RESOLUTION).astype(int)
    c.scalars["info.width"] = width.astype(np.float64)
    c.scalars["info.height"] = height.astype(np.float64)
    c.scalars["info.resolution"] = np.full(s.n, MAP_RESOLUTION)
    c.scalars["info.origin.position.x"] = -span_x - 4.0
    c.scalars["info.origin.position.y"] = -span_y - 4.0
    c.arrays["data"] = lambda i: np.zeros(int(width[i] * height[i]), dtype=np.int8)
    c.frame_id = "map"


def _servo(c: Content, s: Source) -> None:
    source = "pitch" if s.servo_index % 2 == 0 else "roll"
    lagged = _lagged(s.world, source, s.times, SERVO_LAG_S)
    c.scalars["angle"] = lagged + _noise(s.rng, s.n, 0.0005)
    for f in s.topic.fields:
        if f.value != "angle":
            c.scalars[f.value] = np.full(s.n, 0.5 if "neg" not in f.value else -0.5)


def _random(c: Content, s: Source) -> None:
    for path in sorted(s.leaves):
        if path.endswith("[]") or path.startswith("header."):
            continue
        c.scalars[path] = _smooth_random(s.rng, s.times)


# role (role_of) -> what fills its content; any other role carries random signals
ROLE_CONTENT: dict[str, Callable[[Content, Source], None]] = {
    "odometry": _odometry,
    "imu": _imu,
    "scan": _scan,
    "joy": _joy,
    "command": _command,
    "map": _map,
    "servo": _servo,
    "random": _random,
}


def content(
    topic: Topic,
    role: str,
    times: FloatArray,
    world: World,
    rng: np.random.Generator,
    servo_index: int,
    leaves: dict[str, str],
) -> Content:
    """The field values of ``topic`` in ``role`` at its publication ``times``."""
    c = Content()
    fill = ROLE_CONTENT.get(role, _random)
    fill(c, Source(topic, times, world, rng, servo_index, leaves))
    return c
