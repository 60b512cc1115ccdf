"""A small mobile robot's IMU and wheel odometry as recorded arrays, for the learning tests.

The robot drives, turns (±0.5 rad/s) and stands still, a third of the time each, in 20 s
stretches.  The IMU (``sensor_msgs/Imu``, 50 Hz) measures the turn rate with a little noise and
a heading that wanders by ±0.05 rad of magnetometer noise while the robot stands still; the
odometry (``nav_msgs/Odometry``, 50 Hz) integrates the wheels, so its heading is flat at rest.
Value faults are injected on a copy: an IMU heading or gyro whose sign flips, odometry that
freezes or slips.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rac.learn.recording import Recording, Run, TopicData, merge_runs

IMU, ODOM = "/imu/data", "/odom"
IMU_FIELDS = ("angular_velocity.z", "linear_acceleration.x", "linear_acceleration.y", "yaw")
ODOM_FIELDS = ("twist.twist.linear.x", "twist.twist.angular.z", "yaw")


def _smooth(rng: np.random.Generator, n: int, width: int) -> np.ndarray:
    noise = rng.normal(size=n + width)
    out: np.ndarray = np.convolve(noise, np.ones(width) / width, mode="valid")[:n]
    return out / max(float(np.abs(out).max()), 1e-12)


def motion(seed: int, duration: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times (50 Hz), turn rate and forward speed of the robot."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 0.02)
    stretch = (t // 20).astype(int)
    what = rng.integers(0, 3, stretch.max() + 1)[stretch]  # 0 still, 1 drive, 2 turn
    sign = rng.choice([-1.0, 1.0], stretch.max() + 1)[stretch]
    rate = np.where(what == 2, 0.5 * sign, 0.0)
    speed = np.where(what == 1, 1.0, np.where(what == 2, 0.3, 0.0))
    # The base follows its command with a lag of 0.3 s.
    kernel = np.exp(-np.arange(0, 1.5, 0.02) / 0.3)
    kernel /= kernel.sum()
    rate = np.convolve(rate, kernel)[: t.size]
    speed = np.convolve(speed, kernel)[: t.size]
    return t, rate, speed


def run(seed: int, duration: float = 360.0, start: float = 1000.0) -> Run:
    """One healthy recording."""
    rng = np.random.default_rng(seed + 100)
    t, rate, speed = motion(seed, duration)
    heading = np.cumsum(rate) * 0.02
    still = (np.abs(rate) < 1e-3) & (speed < 1e-3)
    wander = 0.05 * _smooth(rng, t.size, 150) * still
    imu = TopicData(
        IMU,
        "sensor_msgs/Imu",
        ("imu_node",),
        start + t + rng.normal(0, 0.0003, t.size),
        np.zeros(t.size, dtype=np.int64),
        IMU_FIELDS,
        np.stack(
            [
                rate + rng.normal(0, 0.01, t.size),
                np.gradient(speed, 0.02) + rng.normal(0, 0.05, t.size),
                speed * rate + rng.normal(0, 0.05, t.size),
                heading + 0.3 + wander,
            ]
        ),
    )
    odom = TopicData(
        ODOM,
        "nav_msgs/Odometry",
        ("base_node",),
        start + 0.005 + t + rng.normal(0, 0.0003, t.size),
        np.zeros(t.size, dtype=np.int64),
        ODOM_FIELDS,
        np.stack([speed, rate, heading]),
    )
    return Run(f"robot{seed}.bag", 1, start, start + duration, (imu, odom), 2 * t.size)


def recording(seed: int, duration: float = 360.0) -> Recording:
    return merge_runs([run(seed, duration)])


def with_fault(
    rec: Recording, topic: str, field: str, start: float, end: float, how: str
) -> Recording:
    """A copy of ``rec`` with a value fault on ``topic.field`` from ``start`` to ``end``
    (seconds from the recording's start): ``flip`` its sign, ``freeze`` it, or ``slip`` (add
    0.6 rad/s to a heading)."""
    origin = min(float(d.times[0]) for d in rec.topics)
    topics = []
    for d in rec.topics:
        if d.name != topic:
            topics.append(d)
            continue
        values = d.values.copy()
        row = d.fields.index(field)
        inside = (d.times - origin >= start) & (d.times - origin < end)
        if how == "flip":
            values[row, inside] = -values[row, inside]
        elif how == "freeze":
            values[row, inside] = values[row, np.argmax(inside) - 1]
        elif how == "slip":
            values[row, inside] += 0.6 * (d.times[inside] - origin - start)
            values[row, d.times - origin >= end] += 0.6 * (end - start)
        topics.append(replace(d, values=values))
    return replace(rec, topics=tuple(topics))
