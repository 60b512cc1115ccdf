"""Value faults written into a copy of a real ROS 1 bag, and parts of a bag cut out.

A sensor that keeps publishing at its rate but says the wrong thing is what a relation can
see and a watchdog cannot.  ``racc synth`` injects faults into the recordings it makes;
these functions inject them into any recording (the shared Jackal bag, a synth run), each
message deserialized, changed and serialized back, every other message copied as it is:

- ``yaw-flip``: an IMU's or odometry's heading changes sign (a magnetometer mounted upside
  down, a driver's sign error); roll and pitch kept;
- ``gyro-flip``: an angular rate about z changes sign;
- ``freeze``: the message's orientation and twist stay what they were when the fault began
  (a driver that repeats its last reading);
- ``slip``: the heading drifts by 0.6 rad/s more than the robot turns (wheels that slip);
- ``stop``: no message at all (the publisher stopped).

Times are seconds from the bag's first message.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_typestore

from rac.learn.fields import euler_from_quaternion, quaternion_from_euler

KINDS = ("yaw-flip", "gyro-flip", "freeze", "slip", "stop")
SLIP_RATE = 0.6  # rad/s


def _orientation(msg: Any) -> tuple[Any, Callable[[Any, Any], Any]]:
    """The message's orientation quaternion and how to put another in its place."""
    if hasattr(msg, "orientation"):
        return msg.orientation, lambda m, q: dataclasses.replace(m, orientation=q)
    pose = msg.pose.pose
    return pose.orientation, lambda m, q: dataclasses.replace(
        m,
        pose=dataclasses.replace(m.pose, pose=dataclasses.replace(m.pose.pose, orientation=q)),
    )


def _with_yaw(msg: Any, change: Callable[[float], float]) -> Any:
    q, put = _orientation(msg)
    yaw, pitch, roll = euler_from_quaternion(q.x, q.y, q.z, q.w)
    x, y, z, w = quaternion_from_euler(
        np.array([change(yaw)]), np.array([pitch]), np.array([roll])
    )[:, 0].tolist()
    return put(msg, dataclasses.replace(q, x=x, y=y, z=z, w=w))


def _with_rate_z(msg: Any, change: Callable[[float], float]) -> Any:
    if hasattr(msg, "angular_velocity"):
        av = msg.angular_velocity
        return dataclasses.replace(msg, angular_velocity=dataclasses.replace(av, z=change(av.z)))
    tw = msg.twist.twist
    angular = dataclasses.replace(tw.angular, z=change(tw.angular.z))
    return dataclasses.replace(
        msg,
        twist=dataclasses.replace(msg.twist, twist=dataclasses.replace(tw, angular=angular)),
    )


def _frozen(msg: Any, first: Any) -> Any:
    """``msg`` with ``first``'s orientation and angular rate (its header, its own)."""
    q, _ = _orientation(first)
    out = _with_yaw(msg, lambda _: euler_from_quaternion(q.x, q.y, q.z, q.w)[0])
    rate = (
        first.angular_velocity.z
        if hasattr(first, "angular_velocity")
        else (first.twist.twist.angular.z)
    )
    return _with_rate_z(out, lambda _: rate)


def inject(bag: Path, out: Path, topic: str, kind: str, start: float, end: float) -> Path:
    """A copy of ``bag`` with a ``kind`` fault on ``topic`` from ``start`` to ``end``."""
    if kind not in KINDS:
        raise ValueError(f"unknown fault kind {kind!r}: one of {', '.join(KINDS)}")
    store = get_typestore(Stores.ROS1_NOETIC)
    out.unlink(missing_ok=True)
    first: Any = None
    with Reader(bag) as reader, Writer(out) as writer:
        origin = reader.start_time * 1e-9
        conns = {
            c.id: writer.add_connection(
                c.topic,
                c.msgtype,
                msgdef=c.msgdef.data,
                md5sum=c.digest,
                callerid=c.ext.callerid,
                latching=c.ext.latching,
            )
            for c in reader.connections
        }
        for conn, stamp, raw in reader.messages():
            t = stamp * 1e-9 - origin
            if conn.topic != topic or not start <= t < end:
                writer.write(conns[conn.id], stamp, raw)
                continue
            if kind == "stop":
                continue
            msg = store.deserialize_ros1(raw, conn.msgtype)
            if kind == "yaw-flip":
                msg = _with_yaw(msg, lambda yaw: -yaw)
            elif kind == "gyro-flip":
                msg = _with_rate_z(msg, lambda z: -z)
            elif kind == "slip":
                msg = _with_yaw(msg, lambda yaw, dt=t - start: yaw + SLIP_RATE * dt)
            else:
                first = msg if first is None else first
                msg = _frozen(msg, first)
            writer.write(conns[conn.id], stamp, store.serialize_ros1(msg, conn.msgtype))
    return out


def cut(bag: Path, out: Path, start: float, end: float = math.inf) -> Path:
    """The messages of ``bag`` from ``start`` to ``end`` (seconds from its first)."""
    out.unlink(missing_ok=True)
    with Reader(bag) as reader, Writer(out) as writer:
        origin = reader.start_time * 1e-9
        conns = {
            c.id: writer.add_connection(
                c.topic,
                c.msgtype,
                msgdef=c.msgdef.data,
                md5sum=c.digest,
                callerid=c.ext.callerid,
                latching=c.ext.latching,
            )
            for c in reader.connections
        }
        for conn, stamp, raw in reader.messages():
            if start <= stamp * 1e-9 - origin < end:
                writer.write(conns[conn.id], stamp, raw)
    return out
