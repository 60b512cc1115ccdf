"""Which signal pairs are worth relating, and why: the reading of every candidate.

A learned relation is only worth its observer if it means something.  The candidates come in
the order of what they mean (docs/learning.md):

1. **graph**: a node's input against its output, the pairs that isolate a node.  Along an
   edge (node n subscribes to i and publishes o, which i affects) of one message type (a
   relay, a throttle, a filter) the same field of both; of two types (a controller: the
   command against the odometry it causes) the pairs of one physical quantity (below), and
   when there is none every field of one against every field of the other.
2. **semantic**: one physical quantity measured twice on the robot's body, known from the
   message types and REP 103/105 (angles in radians about x, y, z of the body; rates in
   rad/s; velocities in the body's frame): a heading from the IMU and from odometry; a turn
   rate (``angular_velocity.z``, ``twist.twist.angular.z``, a command's ``angular.z``)
   against another turn rate and, integrated, against a heading (the change of a heading
   is its turn rate); a velocity against another (commanded against measured); a joint
   position against the integral of its velocity.  Only measurements are paired this way,
   not their copies: a topic published by a node that has an input of the same type is a
   copy of that input, related to it by its graph edge.
3. **unexplained**: every other pair, tried only with ``--blind`` or when nothing above
   applies.  They need stronger evidence (the family of every pair tried) and the report
   marks them for review.

The number of candidates grows with the graph's edges and the measurements, not with the
square of the fields: a recording of 100 relays of one sensor has 100 edges.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from rac.ir import Node
from rac.learn.fields import EULER_FIELDS
from rac.learn.trends import Signal

GRAPH, SEMANTIC, UNEXPLAINED = "graph", "semantic", "unexplained"
_AXES = ("x", "y", "z")
_ANGLE_AXIS = {"yaw": "z", "pitch": "y", "roll": "x"}
_ANGLE_NAME = {"z": "heading", "y": "pitch", "x": "roll"}
_RATE_NAME = {"z": "turn rate", "y": "pitch rate", "x": "roll rate"}
JOINT_STATE = "sensor_msgs/JointState"
COMMAND_TYPES = frozenset({"geometry_msgs/Twist"})  # an unstamped Twist is a command


@dataclass(frozen=True, slots=True)
class Reading:
    """What a candidate pair means."""

    kind: str  # GRAPH, SEMANTIC or UNEXPLAINED
    text: str  # "base: /cmd_vel → /odom (turn rate)", "heading measured twice", …
    edge: tuple[str, str, str] | None = None  # (node, input topic, output topic)

    @property
    def tier(self) -> int:
        """1: judged in the small family of meaningful pairs; 2: in the family of all."""
        return 2 if self.kind == UNEXPLAINED else 1


@dataclass(frozen=True, slots=True)
class Candidate:
    a: Signal
    b: Signal
    reading: Reading

    @property
    def key(self) -> frozenset[Signal]:
        return frozenset((self.a, self.b))


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """What candidates are made of: a topic's type and its varying fields."""

    name: str
    msg_type: str
    fields: tuple[str, ...]


def quantity(msg_type: str, field: str) -> tuple[str, str] | None:
    """The physical quantity a field measures, (kind, axis): ("angle", "z") for a derived
    yaw, ("rate", "z") for an angular velocity about z, ("velocity", "x") for a twist's
    linear x, ("joint", "position"|"velocity") for a JointState's arrays; None for others."""
    if field in _ANGLE_AXIS:
        return "angle", _ANGLE_AXIS[field]
    if msg_type == JOINT_STATE and field in ("position", "velocity"):
        return "joint", field
    parts = field.split(".")
    if len(parts) >= 2 and parts[-1] in _AXES:
        if parts[-2] in ("angular_velocity", "angular"):
            return "rate", parts[-1]
        if parts[-2] == "linear" and ("twist" in parts[:-2] or msg_type in COMMAND_TYPES):
            return "velocity", parts[-1]
    return None


def semantic_pairs(
    a: TopicInfo, b: TopicInfo, steady: set[str]
) -> list[tuple[Signal, Signal, str]]:
    """The pairs of one quantity between the fields of ``a`` and ``b`` (``a`` may be
    ``b``: a rate against its own message's angle), with what they mean.  A side is
    integrated only on a topic published at a steady rate."""
    same = a.name == b.name
    out: list[tuple[Signal, Signal, str]] = []
    for fa in a.fields:
        ka = quantity(a.msg_type, fa)
        if ka is None:
            continue
        for fb in b.fields:
            kb = quantity(b.msg_type, fb)
            if kb is None:
                continue
            if not same and ka == kb:
                text = _twice(ka, a, b)
                if text:
                    out.append((Signal(a.name, fa, False), Signal(b.name, fb, False), text))
            for (rt, rf, rk), (gt, gf, gk) in (
                ((a, fa, ka), (b, fb, kb)),
                ((b, fb, kb), (a, fa, ka)),
            ):
                if rt.name not in steady:
                    continue
                if rk[0] == "rate" and gk == ("angle", rk[1]):
                    text = f"{_RATE_NAME[rk[1]]} against the change of {_ANGLE_NAME[rk[1]]}"
                elif rk == ("joint", "velocity") and gk == ("joint", "position") and same:
                    text = "joint position against the integral of its velocity"
                else:
                    continue
                out.append((Signal(rt.name, rf, True), Signal(gt.name, gf, False), text))
    return _unique(out)


def _twice(kind: tuple[str, str], a: TopicInfo, b: TopicInfo) -> str:
    """What one quantity measured on two topics means ("" when nothing)."""
    what, axis = kind
    if what == "angle":
        return f"{_ANGLE_NAME[axis]} measured twice"
    if what == "rate":
        return f"{_RATE_NAME[axis]} measured twice"
    if what == "velocity":
        if (a.msg_type in COMMAND_TYPES) != (b.msg_type in COMMAND_TYPES):
            return f"commanded against measured velocity ({axis})"
        return f"velocity ({axis}) measured twice"
    if kind == ("joint", "position"):
        return "joint positions measured twice"
    return ""


def _unique(found: Iterable[tuple[Signal, Signal, str]]) -> list[tuple[Signal, Signal, str]]:
    seen: set[frozenset[Signal]] = set()
    out = []
    for a, b, text in found:
        key = frozenset((a, b))
        if key not in seen and a != b:
            seen.add(key)
            out.append((a, b, text))
    return out


def edges(nodes: Sequence[Node]) -> list[tuple[str, str, str]]:
    """(node, input, output) of every publication and each input that affects it (all the
    node's subscriptions when the publication names none)."""
    out = []
    for node in nodes:
        for p in node.publishes:
            inputs = p.affected_by or node.subscribes
            for i in inputs:
                if i.value != p.topic.value:
                    out.append((node.name.value, i.value, p.topic.value))
    return out


def copies(nodes: Sequence[Node], types: Mapping[str, str]) -> set[str]:
    """Topics that copy an input of the same type (a relay's output): not measurements."""
    return {o for _, i, o in edges(nodes) if types.get(i) and types.get(i) == types.get(o)}


def candidates(
    topics: Sequence[TopicInfo], nodes: Sequence[Node], steady: set[str], blind: bool
) -> list[Candidate]:
    """Every candidate pair, graph ones first, then semantic, then (with ``blind``)
    unexplained, each pair once under its first reading."""
    info = {t.name: t for t in topics}
    out: list[Candidate] = []
    seen: set[frozenset[Signal]] = set()

    def add(a: Signal, b: Signal, reading: Reading) -> None:
        key = frozenset((a, b))
        if a != b and key not in seen:
            seen.add(key)
            out.append(Candidate(a, b, reading))

    for node, i, o in edges(nodes):
        if i not in info or o not in info:
            continue
        ti, to = info[i], info[o]
        where = f"{node}: {i} → {o}"
        if ti.msg_type == to.msg_type:
            for f in ti.fields:
                if f in to.fields:
                    add(
                        Signal(i, f, False),
                        Signal(o, f, False),
                        Reading(GRAPH, where, (node, i, o)),
                    )
            continue
        meaning = semantic_pairs(ti, to, steady)
        for a, b, text in meaning:
            add(a, b, Reading(GRAPH, f"{where} ({text})", (node, i, o)))
        if meaning:
            continue
        for a, b in _all_pairs(ti, to, steady):
            add(a, b, Reading(GRAPH, where, (node, i, o)))
    derived = copies(nodes, {t.name: t.msg_type for t in topics})
    measured = [t for t in sorted(topics, key=lambda t: t.name) if t.name not in derived]
    for k, first in enumerate(measured):
        for second in measured[k:]:
            for x, y, text in semantic_pairs(first, second, steady):
                add(x, y, Reading(SEMANTIC, text))
    if blind or not out:
        ordered = sorted(topics, key=lambda t: t.name)
        for k, first in enumerate(ordered):
            for second in ordered[k:]:
                for x, y in _all_pairs(first, second, steady):
                    add(x, y, Reading(UNEXPLAINED, "no reading: review it"))
    return out


def _all_pairs(a: TopicInfo, b: TopicInfo, steady: set[str]) -> list[tuple[Signal, Signal]]:
    """Algorithm 16's pairs of two topics (or of one topic's fields): both raw, or one side
    integrated (on a steady topic); never a field with itself or with its own integral."""
    out = []
    same = a.name == b.name
    for i, fa in enumerate(a.fields):
        for j, fb in enumerate(b.fields):
            if same and j <= i:
                continue
            out.append((Signal(a.name, fa, False), Signal(b.name, fb, False)))
            if a.name in steady:
                out.append((Signal(a.name, fa, True), Signal(b.name, fb, False)))
            if b.name in steady:
                out.append((Signal(a.name, fa, False), Signal(b.name, fb, True)))
    return out


def candidate_fields(fields: Sequence[str]) -> tuple[str, ...]:
    """A topic's fields without the raw components of an orientation quaternion when its
    derived angles are there: a component's trend depends on the heading (cos(yaw/2) rises
    in one half turn and falls in the other), the angles' do not."""
    if not set(EULER_FIELDS) & set(fields):
        return tuple(fields)
    return tuple(f for f in fields if not quaternion_component(f))


def quaternion_component(field_name: str) -> bool:
    """``orientation.w``, ``pose.pose.orientation.z``, …: a component of an orientation."""
    prefix, _, last = field_name.rpartition(".")
    return last in ("x", "y", "z", "w") and prefix.rsplit(".", 1)[-1] == "orientation"
