"""The per-role content functions of ``rac.synth.sensors`` (engine level, no bag written)."""

from __future__ import annotations

import numpy as np
import pytest

from rac.ir import Name, Topic
from rac.synth.sensors import ROLE_CONTENT, Content, content, role_of
from rac.synth.world import simulate

TYPES = {
    "odometry": "nav_msgs/msg/Odometry",
    "imu": "sensor_msgs/Imu",
    "scan": "sensor_msgs/LaserScan",
    "joy": "sensor_msgs/Joy",
    "command": "geometry_msgs/Twist",
    "map": "nav_msgs/OccupancyGrid",
}


def _topic(name: str, msg_type: str | None, fields: tuple[str, ...] = ()) -> Topic:
    return Topic(Name(name), msg_type=msg_type, fields=tuple(Name(f) for f in fields))


def _content(topic: Topic, role: str, seed: int = 1) -> Content:
    rng = np.random.default_rng(seed)
    world = simulate(5.0, rng, ())
    times = np.linspace(0.0, 4.0, 9)
    return content(topic, role, times, world, rng, 0, {"data.a": "float64", "data.b": "float64"})


def test_every_role_has_its_function() -> None:
    roles = {role_of(_topic("/t", kind)) for kind in TYPES.values()}
    roles |= {role_of(_topic("/servo1", None, ("angle",))), role_of(_topic("/x", None))}
    assert roles == set(ROLE_CONTENT) == {*TYPES, "servo", "random"}


@pytest.mark.parametrize(
    ("role", "frame", "some_field"),
    [
        ("odometry", "odom", "pose.pose.position.x"),
        ("imu", "imu_link", "linear_acceleration.z"),
        ("scan", "laser", "range_max"),
        ("command", "base_link", "linear.x"),
        ("map", "map", "info.resolution"),
        ("servo", "base_link", "angle"),
        ("random", "base_link", "data.b"),
    ],
)
def test_a_role_fills_its_fields(role: str, frame: str, some_field: str) -> None:
    c = _content(_topic("/servo1", TYPES.get(role), ("angle", "neg_limit")), role)
    assert c.frame_id == frame
    assert c.scalars[some_field].shape == (9,)


def test_joy_gives_arrays_and_an_unknown_role_random_signals() -> None:
    joy = _content(_topic("/joy", TYPES["joy"]), "joy")
    assert joy.arrays["axes"](0).shape == (4,) and joy.arrays["buttons"](0).shape == (8,)
    other = _content(_topic("/x", None), "no such role")
    same = _content(_topic("/x", None), "random")
    assert other.scalars.keys() == same.scalars.keys() == {"data.a", "data.b"}
    assert all(np.array_equal(other.scalars[k], same.scalars[k]) for k in other.scalars)
