"""How observations, diagnoses and board measurements travel as diagnostic statuses.

Every runtime topic of racc is a standard ``diagnostic_msgs/DiagnosticArray`` (ROS 1) or
``diagnostic_msgs/msg/DiagnosticArray`` (ROS 2), so no message package needs building and
``rostopic echo`` or rqt_robot_monitor show them.  This module fixes the meaning of each
status's fields once, as plain data (:class:`Row`); a transport only copies a row into its
message type and back.  docs/runtime.md documents the same mapping for users.

``/observations``, one row per literal::

    name         the atom, always positive: "ok(pose)", "running(jaguar_node)"
    level        0 (OK) for the literal, 2 (ERROR) for its negation
    message      the literal: "ok(pose)" or "not_ok(pose)"
    hardware_id  the observer that reported it: "pose_gobs"
    values       since: when the observer's verdict last changed (wall-clock s since 1970)

``/diagnosis``, one row per minimal diagnosis (no rows: the robot is healthy)::

    name         "diagnosis 1", "diagnosis 2", ... (fewest faulty components first)
    level        2 (ERROR)
    message      the faulty components, comma-separated: "jaguar_node"
    hardware_id  the robot's name
    values       bad: the faulty components; good: every other component (comma-separated)

When no diagnosis explains the observations, one row named "no diagnosis" (level 2)
says so.  ``/board_measurements``, one row per board channel::

    name "channel N", level 0, message "on" or "off", hardware_id the device on it
    (or ""), values on (1 or 0), current (A), voltage (V)
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rac.diagnosis import DiagnosisResult
from rac.logic import NEG_PREFIX, parse_atom
from rac.observe import ChannelState, Verdict

OK, WARN, ERROR, STALE = 0, 1, 2, 3
# The topics of the runtime's status arrays (the summary goes to /diagnostics,
# rac.passes.observers.DIAGNOSTICS_TOPIC).
OBSERVATIONS = "/observations"
DIAGNOSIS = "/diagnosis"
REPAIR_LOG = "/repair_log"
REPAIR_PLAN = "/repair_plan"  # the plan awaiting an operator's confirmation (advisory mode)
NO_DIAGNOSIS = "no diagnosis"


@dataclass(frozen=True, slots=True)
class Row:
    """One ``DiagnosticStatus``, transport-free."""

    name: str
    level: int
    message: str
    hardware_id: str = ""
    values: tuple[tuple[str, str], ...] = ()

    def value(self, key: str, default: str = "") -> str:
        return dict(self.values).get(key, default)


def row_from_status(status: Any) -> Row:
    """A ``diagnostic_msgs/DiagnosticStatus`` of either ROS as a :class:`Row`."""
    level = status.level
    if isinstance(level, bytes):  # a 'byte' field: bytes in rclpy, sometimes in rospy
        level = level[0] if level else 0
    return Row(
        name=status.name,
        level=int(level),
        message=status.message,
        hardware_id=status.hardware_id,
        values=tuple((kv.key, kv.value) for kv in status.values),
    )


def rows_from_array(array: Any) -> list[Row]:
    """The statuses of a ``diagnostic_msgs/DiagnosticArray`` of either ROS."""
    return [row_from_status(s) for s in array.status]


# -- /observations ---------------------------------------------------------------------


def literal_row(verdict: Verdict, observer: str, since: float | None = None) -> Row:
    """``since`` defaults to the verdict's own time."""
    return Row(
        name=str(verdict.atom),
        level=OK if verdict.positive else ERROR,
        message=str(verdict),
        hardware_id=observer,
        values=(("since", f"{verdict.t if since is None else since:.3f}"),),
    )


def row_verdict(row: Row, t: float) -> Verdict | None:
    """The literal a ``/observations`` row carries (None: not one of ours).

    The message holds the literal; a row from another tool may only have the atom as its
    name, and then its level says whether it holds.
    """
    text = row.message.strip()
    positive = not text.startswith(NEG_PREFIX)
    try:
        return Verdict(t, parse_atom(text.removeprefix(NEG_PREFIX)), positive)
    except ValueError:
        pass
    try:
        return Verdict(t, parse_atom(row.name.strip()), row.level in (OK, WARN))
    except ValueError:
        return None


# -- /diagnosis --------------------------------------------------------------------------


def diagnosis_rows(result: DiagnosisResult, robot: str) -> tuple[Row, ...]:
    if result.consistent:
        return ()
    if not result.diagnoses:
        why = "the observations contradict the model: no set of faulty components explains them"
        return (Row(NO_DIAGNOSIS, ERROR, why, robot),)
    return tuple(
        Row(
            name=f"diagnosis {i}",
            level=ERROR,
            message=",".join(bad),
            hardware_id=robot,
            values=(("bad", ",".join(bad)), ("good", ",".join(result.good(bad)))),
        )
        for i, bad in enumerate(result.diagnoses, 1)
    )


def row_diagnosis(row: Row) -> tuple[str, ...] | None:
    """The faulty components of a ``/diagnosis`` row (None: the "no diagnosis" row)."""
    if row.name == NO_DIAGNOSIS:
        return None
    text = row.value("bad", row.message)
    return tuple(sorted(c for c in (p.strip() for p in text.split(",")) if c))


def summary_row(node: str, robot: str, result: DiagnosisResult, observations: int) -> Row:
    """The engine's one status on ``/diagnostics``."""
    if result.consistent:
        level, message = OK, "no fault"
    elif result.diagnoses:
        shown = " | ".join(",".join(d) for d in result.diagnoses[:3])
        more = f" (+{len(result.diagnoses) - 3} more)" if len(result.diagnoses) > 3 else ""
        level, message = ERROR, f"faulty: {shown}{more}"
    else:
        level, message = ERROR, "no diagnosis explains the observations"
    values = (("observations", str(observations)), ("diagnoses", str(len(result.diagnoses))))
    return Row(f"{node}: diagnosis", level, message, robot, values)


# -- /board_measurements --------------------------------------------------------------------


def channel_rows(
    readings: Sequence[tuple[bool, float, float]], devices: Mapping[int, str]
) -> tuple[Row, ...]:
    """One row per channel (1-based) from (on, current, voltage) readings."""
    return tuple(
        Row(
            name=f"channel {n}",
            level=OK,
            message="on" if on else "off",
            hardware_id=devices.get(n, ""),
            values=(("on", "1" if on else "0"), ("current", f"{i:.3f}"), ("voltage", f"{v:.3f}")),
        )
        for n, (on, i, v) in enumerate(readings, 1)
    )


def row_channel(row: Row, t: float) -> ChannelState | None:
    name = row.name.strip()
    if not name.startswith("channel ") or not name[8:].strip().isdigit():
        return None
    on = row.value("on", "1" if row.message.strip() == "on" else "0") == "1"
    return ChannelState(t, int(name[8:]), on)


def rows_text(rows: Iterable[Row]) -> list[str]:
    """``level name: message`` lines, for logs."""
    return [f"{r.level} {r.name}: {r.message}" for r in rows]
