"""What the observers read and what they report (Definition 5.1, §5.2).

The observer core is transport-free: a replay, a ROS 1 or a ROS 2 runtime turns its inputs
into these events, and the observers turn events into :class:`Verdict` literals.  Times are
seconds on any clock that does not run backwards within one stream.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from rac.logic import NEG_PREFIX, Atom


@dataclass(frozen=True, slots=True)
class Message:
    """One occurrence on a topic (Definition 5.1).

    ``values`` maps a field path as the model writes it (``yaw``,
    ``twist.twist.angular.z``) to its value; only fields some observer asked for need be
    present.  A missing or non-finite value is "not available" and skipped by the observers
    that read values; the occurrence still counts for the topic's frequency.

    ``t`` is when the message was received.  ``stamp`` is its ``header.stamp`` in seconds
    when its type begins with a ``std_msgs/Header`` and the stamp is not zero (None
    otherwise): the publisher's own time, on the publisher's clock.  Only differences of
    stamps mean anything to an observer (a bag played back keeps stamps years old).
    ``seq`` is its ``header.seq`` (ROS 1; None otherwise): where the publisher counts its
    messages, how many it sent between two that arrived.
    """

    t: float
    topic: str
    values: Mapping[str, float]
    stamp: float | None = None
    seq: int | None = None


@dataclass(frozen=True, slots=True)
class NodeSample:
    """One liveness sample of one node (NObs); ``node`` as in the model, no leading '/'."""

    t: float
    node: str
    running: bool


@dataclass(frozen=True, slots=True)
class PropertySample:
    """One cpu/mem sample of one node (PObs): ``cpu`` in percent of one core, ``mem`` bytes."""

    t: float
    node: str
    prop: str
    value: float


@dataclass(frozen=True, slots=True)
class DeviceStatus:
    """One ``diagnostic_msgs/DiagnosticStatus`` from ``/diagnostics`` (DObs)."""

    t: float
    name: str
    hardware_id: str
    level: int  # 0 OK, 1 WARN, 2 ERROR, 3 STALE


@dataclass(frozen=True, slots=True)
class ChannelState:
    """One board measurement of one power channel (HObs, Algorithm 6)."""

    t: float
    channel: int
    on: bool


Event = Message | NodeSample | PropertySample | DeviceStatus | ChannelState


@dataclass(frozen=True, slots=True)
class Verdict:
    """An observer's output literal at time ``t``: ``atom`` or, when not positive, ¬atom."""

    t: float
    atom: Atom
    positive: bool

    def __str__(self) -> str:
        return str(self.atom) if self.positive else f"{NEG_PREFIX}{self.atom}"
