"""How large a field's value can honestly be: beyond it, a value is a glitch, not a signal.

An observer keeps running sums (regressions, integrals).  One value of 1e308 turns a sum
into infinity, and one of 1e20 swallows every later increment of an integral: the observer
would read the signal wrong for good.  A value beyond its field's plausible magnitude is
therefore never added to a sum; it is evidence about its publisher for the observer's
window (the relation's check counts it as violated), nothing more.

The bounds are in the units REP 103 fixes for ROS messages (metres, radians, seconds and
their ratios) and wide: they must never refuse a real robot's value, only one no sensor or
estimator can produce.  A field the rules do not recognise gets :data:`GENERIC_BOUND`.
"""

from __future__ import annotations

import math

GENERIC_BOUND = 1e12  # any quantity of a ROS message in SI units
# (the field path's components that name a quantity, its bound) in the order they are tried
RULES: tuple[tuple[tuple[str, ...], float], ...] = (
    (("orientation",), 1.5),  # quaternion components: at most 1 when normalised
    (("angular_velocity",), 1e4),  # rad/s: 10,000 rad/s is about 95,000 rpm
    (("linear_acceleration",), 1e4),  # m/s²: about 1,000 g
    (("angular",), 1e4),  # a twist's angular velocity, rad/s
    (("linear",), 1e5),  # a twist's linear velocity, m/s (about Mach 300)
    (("position",), 1e9),  # m (a pose) or rad (a joint): beyond the Earth's orbit of its own
)


def bound(field: str) -> float:
    """The largest magnitude a value of ``field`` (``twist.twist.angular.z``) can have."""
    parts = field.split(".")
    for names, limit in RULES:
        if any(name in parts for name in names):
            return limit
    return GENERIC_BOUND


def plausible(value: float, limit: float) -> bool:
    """Finite and within ``limit`` in magnitude."""
    return math.isfinite(value) and -limit <= value <= limit
