"""``--schedule thesis``: §10.2.2's test run, its faults chosen from the model.

"In each run we drove the robot twice over slippery floor, increased once the memory and
cpu usage of a node, increased the frequency of messages on a topic, and killed once a
node.  All faults were injected and retracted in a sequential order."  So six faults, in
the order :data:`ORDER`, each retracted before the next begins.  Targets, by rule:

- slip: the odometry topic (``nav_msgs/Odometry``, with a publisher), preferring one in a
  declared ``relate`` or ``interval`` pair (an observer can see it slip), then by name.
- freq (five times the rate): that topic if it has a rate, as the thesis did with /pose;
  else the first regular topic by name (an irregular topic has no rate to break).
- cpu: the odometry topic's first publisher by name (the thesis raised p2os's).
- mem: the node with the largest memory limit among those that publish (the thesis doubled
  gmapping's memory, not the viewer's), else among all; ties by name.
- crash: a software node (it drives no hardware) that publishes, preferring one whose
  output feeds a hardware driver (teleop_joy feeds p2os), then one whose output feeds any
  node, then by name.

A kind without a target in the model is skipped, with a note.  After a warm-up of
:data:`WARMUP_S` the remaining time is cut into equal slots, one per fault: a fault starts
at its slot's start and lasts :data:`MAX_FAULT_S` or less, at least :data:`MIN_FAULT_S`,
so that at least :data:`MIN_GAP_S` of recovery follows each fault (also the last).
Times are multiples of 0.1 s.  A crash ends too: the node is back at the fault's end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rac.ir import Model, Node, Topic
from rac.synth.faults import ODOMETRY, Fault

SCHEDULES = ("thesis",)
ORDER = ("slip", "cpu", "mem", "freq", "slip", "crash")
WARMUP_S = 30.0  # observers learn nothing here, but their windows fill
MIN_FAULT_S = 15.0
MAX_FAULT_S = 20.0
MIN_GAP_S = 20.0  # the recovery after each fault, before the next one starts


@dataclass(frozen=True, slots=True)
class Schedule:
    faults: tuple[Fault, ...]
    notes: tuple[str, ...]  # kinds skipped, and why


class TooShort(ValueError):
    """The recording is too short for the schedule's faults."""

    def __init__(self, minimum: float, count: int) -> None:
        super().__init__(f"needs at least {minimum:g} s for its {count} faults")
        self.minimum = minimum
        self.count = count


def minimum_duration(count: int) -> float:
    return WARMUP_S + count * (MIN_FAULT_S + MIN_GAP_S)


def _is_odometry(topic: Topic) -> bool:
    return (topic.msg_type or "").replace("/msg/", "/") == ODOMETRY


def odometry_topic(model: Model) -> Topic | None:
    publishers = model.publishers()
    pairs = [(p.a, p.b) for p in model.related] + [(p.a, p.b) for p in model.intervals]
    related = {ref.topic for pair in pairs for ref in pair}
    candidates = [t for t in model.topics if _is_odometry(t) and t.name.value in publishers]
    if not candidates:
        return None
    return min(candidates, key=lambda t: (t.name.value not in related, t.name.value))


def _crash_target(model: Model) -> Node | None:
    drivers = {n.name.value for n in model.nodes if n.drives}
    readers: dict[str, set[str]] = {}
    for node in model.nodes:
        for topic in node.subscribes:
            readers.setdefault(topic.value, set()).add(node.name.value)

    def fed(node: Node) -> set[str]:
        return {r for t in node.published_topics for r in readers.get(t, ())} - {node.name.value}

    software = [n for n in model.nodes if not n.drives and n.published_topics]
    if not software:
        return None
    return min(
        software,
        key=lambda n: (not fed(n) & drivers, not fed(n), n.name.value),
    )


def thesis_targets(model: Model) -> tuple[tuple[tuple[str, str], ...], tuple[str, ...]]:
    """(kind, target) in :data:`ORDER` for the kinds the model has a target for; notes."""
    odometry = odometry_topic(model)
    publishers = model.publishers()
    targets: dict[str, str | None] = {"slip": None, "freq": None, "cpu": None}
    why = {
        "slip": f"no published odometry topic ({ODOMETRY})",
        "cpu": f"no published odometry topic ({ODOMETRY}) whose publisher to load",
        "freq": "no regular topic (one with a rate)",
        "mem": "no node has a memory limit",
        "crash": "no software node (driving no hardware) publishes a topic",
    }
    if odometry is not None:
        targets["slip"] = odometry.name.value
        targets["cpu"] = sorted(publishers[odometry.name.value])[0]
    regular = sorted(
        (t for t in model.topics if t.rate_hz is not None and t.name.value in publishers),
        key=lambda t: (t is not odometry, t.name.value),
    )
    targets["freq"] = regular[0].name.value if regular else None
    limited = [n for n in model.nodes if n.limits.mem is not None]
    limited = [n for n in limited if n.publishes] or limited
    biggest = min(limited, key=lambda n: (-(n.limits.mem or 0), n.name.value), default=None)
    targets["mem"] = biggest.name.value if biggest else None
    crash = _crash_target(model)
    targets["crash"] = crash.name.value if crash else None
    chosen = tuple((k, t) for k in ORDER if (t := targets[k]) is not None)
    notes = tuple(f"{k} skipped: {why[k]}" for k in dict.fromkeys(ORDER) if targets[k] is None)
    return chosen, notes


def thesis_schedule(model: Model, duration: float) -> Schedule:
    """The thesis's faults spread over ``duration``; :class:`TooShort` when it is too short."""
    chosen, notes = thesis_targets(model)
    count = len(chosen)
    if not count:
        return Schedule((), notes)
    minimum = minimum_duration(count)
    if duration < minimum:
        raise TooShort(minimum, count)
    # Whole tenths; the epsilon keeps 349.99999... from flooring a slot below the minimum.
    slot = math.floor((duration - WARMUP_S) * 10 / count + 1e-6) / 10
    length = round(min(MAX_FAULT_S, slot - MIN_GAP_S), 1)
    faults = tuple(
        Fault(kind, round(WARMUP_S + i * slot, 1), length, target)
        for i, (kind, target) in enumerate(chosen)
    )
    return Schedule(faults, notes)
