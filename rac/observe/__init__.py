"""The observer core (chapter 5): observers as pure, transport-free state machines.

A runtime (a replay, a ROS 1 or ROS 2 node) turns what it sees into events
(:mod:`rac.observe.events`), feeds them to an :class:`ObserverBank` built from the compiled
observer specs, tells it when time passes, and merges the verdicts into an
:class:`ObservationSet` (Algorithm 10) for the diagnosis engine.
"""

from rac.observe.bank import ObserverBank
from rac.observe.base import Needs, Observer
from rac.observe.build import build, build_all
from rac.observe.collect import ObservationSet
from rac.observe.events import (
    ChannelState,
    DeviceStatus,
    Event,
    Message,
    NodeSample,
    PropertySample,
    Verdict,
)

__all__ = [
    "ChannelState",
    "DeviceStatus",
    "Event",
    "Message",
    "Needs",
    "NodeSample",
    "ObservationSet",
    "Observer",
    "ObserverBank",
    "PropertySample",
    "Verdict",
    "build",
    "build_all",
]
