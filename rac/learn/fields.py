"""Which values of a message become signals: the field layout of a message type.

A message is flattened into dotted paths (``pose.pose.position.x``).  Numeric scalars are
signals; numeric arrays and everything under a ``std_msgs/Header`` are skipped unless a
pattern includes them (an included array contributes the mean of its finite elements).
A message holding an orientation quaternion also yields the derived signals ``yaw``,
``pitch`` and ``roll`` (the convention docs/learning.md describes).
"""

from __future__ import annotations

import fnmatch
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from rosbags.interfaces import Nodetype

NUMERIC_TYPES = frozenset(
    {"bool", "byte", "char", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32"}
    | {"uint64", "float32", "float64", "octet"}
)
HEADER_TYPE = "std_msgs/msg/Header"
QUATERNION_TYPE = "geometry_msgs/msg/Quaternion"
PLACEHOLDER = "structure_needs_at_least_one_member"  # how ROS 2 fills empty messages
EULER_FIELDS = ("yaw", "pitch", "roll")

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class FieldSelector:
    """Decides which paths of a topic become signals.

    ``declared`` maps a topic to the fields a base model declares for it: when a topic is
    there, only those fields are taken; ``include`` patterns (``ranges``, ``header.*``,
    ``/scan.ranges``) add any field, arrays and header fields too.
    """

    declared: Mapping[str, frozenset[str]] | None = None
    include: tuple[str, ...] = ()

    def included(self, topic: str, path: str) -> bool:
        return any(
            fnmatch.fnmatchcase(path, p) or fnmatch.fnmatchcase(f"{topic}.{path}", p)
            for p in self.include
        )

    def wanted(self, topic: str, path: str, *, plain: bool) -> bool:
        """``plain`` is False for arrays and header fields, which only patterns include, or
        a model that declares them (a learned JointState relation on ``position`` is read
        in replay and on the robot as it was learned: the mean of the array)."""
        if self.included(topic, path):
            return True
        if self.declared is not None and path in self.declared.get(topic, ()):
            return True
        if not plain:
            return False
        if self.declared is None or topic not in self.declared:
            return True
        return path in self.declared[topic]


@dataclass(frozen=True, slots=True)
class Layout:
    """The signals of one message type on one topic and how to read them from a message."""

    scalars: tuple[str, ...]
    arrays: tuple[str, ...]
    quaternion: str | None  # path of the first orientation quaternion, "" for the message
    euler: tuple[str, ...]  # which of yaw, pitch, roll are wanted

    @property
    def fields(self) -> tuple[str, ...]:
        return (*self.scalars, *self.arrays, *self.euler)

    @property
    def empty(self) -> bool:
        return not self.fields


def _walk(
    fielddefs: Mapping[str, Any], typename: str, prefix: str, under_header: bool
) -> list[tuple[str, str, bool]]:
    """(path, kind, under_header) of every leaf; kind is scalar, array or quaternion."""
    out: list[tuple[str, str, bool]] = []
    if typename == QUATERNION_TYPE:
        out.append((prefix.rstrip("."), "quaternion", under_header))
    for name, (nodetype, detail) in fielddefs[typename][1]:
        path = prefix + name
        if name == PLACEHOLDER:
            continue
        if nodetype == Nodetype.BASE:
            if detail[0] in NUMERIC_TYPES:
                out.append((path, "scalar", under_header))
        elif nodetype == Nodetype.NAME:
            header = under_header or detail == HEADER_TYPE
            out.extend(_walk(fielddefs, detail, path + ".", header))
        elif nodetype in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            inner_type, inner = detail[0]
            if inner_type == Nodetype.BASE and inner[0] in NUMERIC_TYPES:
                out.append((path, "array", under_header))
    return out


def layout_of(
    fielddefs: Mapping[str, Any], typename: str, topic: str, selector: FieldSelector
) -> Layout:
    leaves = _walk(fielddefs, typename, "", False)
    scalars = tuple(
        p
        for p, kind, hdr in leaves
        if kind == "scalar" and selector.wanted(topic, p, plain=not hdr)
    )
    arrays = tuple(
        p for p, kind, _ in leaves if kind == "array" and selector.wanted(topic, p, plain=False)
    )
    quaternions = [p for p, kind, hdr in leaves if kind == "quaternion" and not hdr]
    quaternion = quaternions[0] if quaternions else None
    top_level = {p for p, _, _ in leaves if "." not in p}
    euler: tuple[str, ...] = ()
    if quaternion is not None:
        euler = tuple(
            e for e in EULER_FIELDS if e not in top_level and selector.wanted(topic, e, plain=True)
        )
    return Layout(scalars, arrays, quaternion if euler else None, euler)


def _getter(path: str) -> Callable[[object], Any]:
    """Reads a dotted path; "" is the message itself (a quaternion topic's quaternion)."""
    parts = path.split(".") if path else []

    def get(msg: object) -> Any:
        for part in parts:
            msg = getattr(msg, part)
        return msg

    return get


def row_extractor(layout: Layout) -> Callable[[object], tuple[float, ...]]:
    """A function reading one deserialized message's row: the scalars, the arrays' means,
    then the quaternion's x, y, z, w when angles are wanted (:func:`with_angles` turns a
    matrix of rows into the layout's values)."""
    scalar_getters = [_getter(p) for p in layout.scalars]
    array_getters = [_getter(p) for p in layout.arrays]
    quat_getter = None if layout.quaternion is None else _getter(layout.quaternion)

    def extract(msg: object) -> tuple[float, ...]:
        values = [float(g(msg)) for g in scalar_getters]
        values.extend(finite_mean(g(msg)) for g in array_getters)
        if quat_getter is not None:
            q = quat_getter(msg)
            values.extend((float(q.x), float(q.y), float(q.z), float(q.w)))
        return tuple(values)

    return extract


def extractor(layout: Layout) -> Callable[[object], tuple[float, ...]]:
    """A function reading the layout's values from one deserialized message."""
    row = row_extractor(layout)
    which = [EULER_FIELDS.index(e) for e in layout.euler]
    if not which:
        return row

    def extract(msg: object) -> tuple[float, ...]:
        values = row(msg)
        angles = euler_from_quaternion(*values[-4:])
        return (*values[:-4], *(angles[i] for i in which))

    return extract


def with_angles(layout: Layout, rows: FloatArray) -> FloatArray:
    """Rows (messages × row values, as :func:`row_extractor` reads them) -> the layout's
    values: the quaternion's four columns become the wanted angles, computed per column
    with the same numpy functions as :func:`euler_from_quaternion` (the same bits)."""
    if not layout.euler:
        return rows
    x, y, z, w = rows[:, -4:].T
    angles = euler_angles(x, y, z, w)
    which = [angles[EULER_FIELDS.index(e)] for e in layout.euler]
    out: FloatArray = np.column_stack([rows[:, :-4], *which])
    return out


def finite_mean(values: Any) -> float:
    """The mean of an array's finite elements (NaN when it has none): an array's signal."""
    arr = np.asarray(values, dtype=np.float64)
    finite = arr[np.isfinite(arr)]
    return float(finite.mean()) if finite.size else float("nan")


def euler_from_quaternion(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """(yaw, pitch, roll) in radians, the ZYX convention of ROS's tf."""
    yaw = float(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
    pitch = float(np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0)))
    roll = float(np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)))
    return yaw, pitch, roll


def euler_angles(
    x: FloatArray, y: FloatArray, z: FloatArray, w: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`euler_from_quaternion` element-wise over arrays."""
    yaw: FloatArray = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    pitch: FloatArray = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    roll: FloatArray = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    return yaw, pitch, roll


def quaternion_from_euler(yaw: FloatArray, pitch: FloatArray, roll: FloatArray) -> FloatArray:
    """(x, y, z, w) stacked, the inverse of :func:`euler_from_quaternion` (element-wise)."""
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    out: FloatArray = np.stack(
        [
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ]
    )
    return out
