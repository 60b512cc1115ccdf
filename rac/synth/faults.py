"""Faults to inject into a synthetic recording (§10.2.1): ``KIND@T[+D]:TARGET``."""

from __future__ import annotations

import re
from collections.abc import Collection
from dataclasses import dataclass

from rac.errors import Diagnostic, RacError, did_you_mean
from rac.ir import Model

FAULT_KINDS = {
    "slip": "topic",  # the odometry topic whose yaw leaves the IMU's
    "crash": "node",  # the node whose topics stop
    "freq": "topic",  # the topic published five times as often
    "cpu": "node",  # the node whose CPU use rises (properties CSV)
    "mem": "node",  # the node whose memory use doubles, past its limit (properties CSV)
    "trip": "device",  # the switchable device whose supply the board trips (racc demo's)
}
FREQ_FACTOR = 5.0
ODOMETRY = "nav_msgs/Odometry"
FAULT_SPEC = re.compile(r"(?P<kind>[a-z]+)@(?P<t>[0-9.]+)(\+(?P<d>[0-9.]+))?:(?P<target>\S+)")


@dataclass(frozen=True, slots=True)
class Fault:
    kind: str
    start: float  # seconds from the start of the recording
    duration: float | None  # None: until the end
    target: str

    def active(self, t: float) -> bool:
        return t >= self.start and (self.duration is None or t < self.start + self.duration)

    @property
    def end(self) -> float:
        return float("inf") if self.duration is None else self.start + self.duration


def _bad(spec: str, why: str, hint: str | None = None) -> RacError:
    if hint is None:
        hint = "write KIND@T[+D]:TARGET, e.g. slip@60+10:/pose, crash@120:joy_node, freq@90:/scan"
    return RacError([Diagnostic("RAC083", f"fault '{spec}': {why}", hint=hint)])


def parse_fault(spec: str, model: Model, duration: float | None = None) -> Fault:
    """The fault ``spec`` names, checked against the model (and the recording's duration):
    a fault the recording would not show would be false ground truth."""
    match = FAULT_SPEC.fullmatch(spec.strip())
    if match is None:
        raise _bad(spec, "not of the form KIND@T[+D]:TARGET")
    kind, target = match["kind"], match["target"]
    if kind not in FAULT_KINDS:
        why = f"unknown kind '{kind}' (one of {', '.join(FAULT_KINDS)})"
        raise _bad(spec, why, did_you_mean(kind, FAULT_KINDS))
    names: Collection[str] = (
        model.topic_by_name() if FAULT_KINDS[kind] == "topic" else model.node_by_name()
    )
    if kind == "trip":
        # A trip needs a device on a board channel: the board measures and switches it.
        names = sorted(h.name.value for h in model.hardware if h.switchable and h.channel)
    if target not in names:
        what = "switchable device on a board channel" if kind == "trip" else FAULT_KINDS[kind]
        why = f"the model has no {what} '{target}' (one of {', '.join(sorted(names)) or 'none'})"
        raise _bad(spec, why, did_you_mean(target, names))
    topic = model.topic_by_name().get(target)
    odometry = topic is not None and (topic.msg_type or "").replace("/msg/", "/") == ODOMETRY
    if kind == "slip" and not odometry:
        raise _bad(spec, f"slip needs an odometry topic ({ODOMETRY}), not '{target}'")
    if FAULT_KINDS[kind] == "topic" and target not in model.publishers():
        raise _bad(spec, f"no node publishes '{target}'")
    if kind == "freq" and topic is not None and topic.rate_hz is None:
        raise _bad(spec, f"freq needs a regular topic (one with a rate), not '{target}'")
    try:
        start = float(match["t"])
        length = float(match["d"]) if match["d"] else None
    except ValueError:
        raise _bad(spec, "T and D are seconds") from None
    if length is not None and length <= 0:
        raise _bad(spec, "D must be above 0 s")
    if duration is not None and start >= duration:
        raise _bad(spec, f"it starts at or after the end of the recording ({duration:g} s)")
    return Fault(kind, start, length, target)
