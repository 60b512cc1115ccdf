"""The one underlying motion every synthetic sensor observes.

A teleoperator switches between driving straight, turning, spinning and stopping; the
robot follows the commands with a lag; the ground has ramps (pitch) and bumps (roll)
that are independent of the heading.  Odometry integrates the wheels' angular velocity,
so a ``slip`` fault makes its yaw leave the true (IMU) yaw.  Everything is sampled on a
fine grid and read at any time by interpolation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rac.learn.fields import FloatArray
from rac.synth.faults import Fault

GRID_HZ = 200.0
MAX_SPEED = 0.5  # m/s
MAX_TURN = 0.8  # rad/s
_COMMANDS = (  # (v, ω) of the teleoperator's manoeuvres
    (MAX_SPEED, 0.0),
    (0.25, 0.6),
    (0.25, -0.6),
    (0.0, MAX_TURN),
    (0.0, -MAX_TURN),
    (0.0, 0.0),
    (MAX_SPEED, 0.25),
    (MAX_SPEED, -0.25),
)
LAG_S = 0.4  # the base follows a command with this time constant
SLIP_RATE = 0.6  # rad/s of extra yaw rate the odometry sees while slipping


@dataclass(frozen=True, slots=True)
class World:
    t: FloatArray
    v_cmd: FloatArray
    w_cmd: FloatArray
    v: FloatArray
    w: FloatArray  # true angular velocity
    yaw: FloatArray  # true heading (what the IMU sees)
    pitch: FloatArray
    roll: FloatArray
    x: FloatArray
    y: FloatArray
    w_odom: FloatArray  # what the wheels report
    yaw_odom: FloatArray
    x_odom: FloatArray
    y_odom: FloatArray
    command_changes: FloatArray  # times the teleoperator moved the stick

    def at(self, name: str, times: FloatArray) -> FloatArray:
        series: FloatArray = getattr(self, name)
        out: FloatArray = np.interp(times, self.t, series)
        return out


def _lag(signal: FloatArray, dt: float, tau: float) -> FloatArray:
    """First-order low pass (exact discretisation), vectorised via a scan over the grid."""
    a = float(np.exp(-dt / tau))
    out = np.empty_like(signal)
    acc = float(signal[0])
    for i, s in enumerate(signal.tolist()):
        acc = a * acc + (1 - a) * s
        out[i] = acc
    return out


def _bumps(
    rng: np.random.Generator, t: FloatArray, every: tuple[float, float], size: float
) -> FloatArray:
    """Raised-cosine ramps of random sign, height and length at random times."""
    out = np.zeros_like(t)
    at = float(rng.uniform(*every))
    while at < t[-1]:
        length = float(rng.uniform(4.0, 10.0))
        height = float(rng.uniform(0.4, 1.0)) * size * float(rng.choice([-1.0, 1.0]))
        inside = (t >= at) & (t < at + length)
        out[inside] += height * 0.5 * (1 - np.cos(2 * np.pi * (t[inside] - at) / length))
        at += length + float(rng.uniform(*every))
    return out


def _integrate(rate: FloatArray, dt: float) -> FloatArray:
    out: FloatArray = np.concatenate([[0.0], np.cumsum(rate[:-1]) * dt])
    return out


def simulate(duration: float, rng: np.random.Generator, faults: Sequence[Fault]) -> World:
    dt = 1.0 / GRID_HZ
    t = np.arange(0.0, duration + 1.0, dt)
    v_cmd = np.zeros_like(t)
    w_cmd = np.zeros_like(t)
    changes = []
    at = 0.0
    while at < t[-1]:
        length = float(rng.uniform(2.0, 7.0))
        v, w = _COMMANDS[int(rng.integers(len(_COMMANDS)))]
        inside = (t >= at) & (t < at + length)
        v_cmd[inside], w_cmd[inside] = v, w
        changes.append(at)
        at += length
    v_true = _lag(v_cmd, dt, LAG_S)
    w_true = _lag(w_cmd, dt, LAG_S)
    yaw = _integrate(w_true, dt)
    slip = np.zeros_like(t)
    for f in faults:
        if f.kind == "slip":
            slip[(t >= f.start) & (t < f.end)] = SLIP_RATE
    w_odom = w_true + slip
    yaw_odom = _integrate(w_odom, dt)
    pitch = _bumps(rng, t, (15.0, 40.0), 0.25)
    roll = _bumps(rng, t, (10.0, 30.0), 0.12)
    return World(
        t=t,
        v_cmd=v_cmd,
        w_cmd=w_cmd,
        v=v_true,
        w=w_true,
        yaw=yaw,
        pitch=pitch,
        roll=roll,
        x=_integrate(v_true * np.cos(yaw), dt),
        y=_integrate(v_true * np.sin(yaw), dt),
        w_odom=w_odom,
        yaw_odom=yaw_odom,
        x_odom=_integrate(v_true * np.cos(yaw_odom), dt),
        y_odom=_integrate(v_true * np.sin(yaw_odom), dt),
        command_changes=np.asarray(changes, dtype=np.float64),
    )
