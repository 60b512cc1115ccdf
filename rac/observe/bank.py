"""ObserverBank: every observer of a model, with each event routed to those that read it."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from types import MappingProxyType
from typing import TypeVar

from rac.logic import Atom
from rac.observe.base import Observer, TimingObserver, plain_node
from rac.observe.build import build_all
from rac.observe.events import (
    ChannelState,
    DeviceStatus,
    Event,
    Message,
    NodeSample,
    PropertySample,
    Verdict,
)
from rac.observe.gobs import GObs
from rac.passes.observers import DIAGNOSTICS_TOPIC, ObserverSpec

K = TypeVar("K")

# Observers that judge the values a topic carries, not when its messages come.
VALUE_KINDS = frozenset({"BiQObs", "IObs"})
_NO_VALUES: Mapping[str, float] = MappingProxyType({})


class ObserverBank:
    """Routes by topic, node, (node, property), device and channel.

    Verdicts of one call come by observer order (the specs' order), then by atom; one
    observer's verdicts on one atom keep their time order.  An event or an advance at a
    time that is not finite is ignored (GObs counts silence and BiQObs steps its grid up to
    a time; NaN or infinity would fail or poison their sums).
    """

    def __init__(self, specs: Iterable[ObserverSpec]) -> None:
        self.observers: tuple[Observer, ...] = build_all(specs)
        self._suspended: set[int] = set()  # observers fed nothing (suspend)
        self._topics: dict[str, list[int]] = {}
        self._nodes: dict[str, list[int]] = {}
        self._properties: dict[tuple[str, str], list[int]] = {}
        self._devices: list[int] = []  # a status names its device in several ways: all see it
        self._channels: dict[int, list[int]] = {}
        fields: dict[str, set[str]] = {}
        for i, obs in enumerate(self.observers):
            needs = obs.needs
            for topic, wanted in needs.topics:
                _add(self._topics, topic, i)
                fields.setdefault(topic, set()).update(wanted)
            for node in needs.nodes:
                _add(self._nodes, node, i)
            for prop in needs.properties:
                _add(self._properties, prop, i)
            if needs.devices:
                self._devices.append(i)
            for channel in needs.channels:
                _add(self._channels, channel, i)
        self._fields = {t: frozenset(f) for t, f in sorted(fields.items())}
        self.nodes = frozenset(self._nodes)
        self.properties = frozenset(self._properties)
        self.devices = frozenset(d for o in self.observers for d in o.needs.devices)
        self.needs_board = bool(self._channels)
        self._index()

    def _index(self) -> None:
        live = [o for i, o in enumerate(self.observers) if i not in self._suspended]
        self._timing = tuple(o for o in live if isinstance(o, TimingObserver))
        self._timed = tuple(o for o in live if o.timed)  # the others never change

    def _readers(self, topic: str) -> list[int]:
        """The observers of ``topic``'s messages; of ``/diagnostics``, the device observers."""
        readers = list(self._topics.get(topic, []))
        return readers + self._devices if topic == DIAGNOSTICS_TOPIC else readers

    def suspend(self, topic: str) -> list[Atom]:
        """Feed and advance none of the observers that read ``topic`` (its messages cannot
        be told from a stranger's); the atoms they report, which are unknown from now on."""
        found = [i for i in self._readers(topic) if i not in self._suspended]
        self._suspended.update(found)
        self._index()
        return [a for i in found for a in self.observers[i].spec.atoms]

    def resume(self, topic: str, keep_values: bool = False) -> list[Atom]:
        """The observers of ``topic`` start again.  Those that time messages start afresh:
        nothing of before counts (a frequency observer would otherwise read the pause as
        silence).  With ``keep_values`` (a short pause), those that judge values (BiQObs,
        IObs) go on from where they stopped: they were fed nothing meanwhile, and a
        relation's history takes many seconds to gather again.  The atoms of the kept
        observers, whose last verdicts hold again."""
        found = [i for i in self._readers(topic) if i in self._suspended]
        if not found:
            return []
        kept = [i for i in found if keep_values and self.observers[i].spec.kind in VALUE_KINDS]
        timed = [i for i in found if i not in kept]
        fresh = build_all(self.observers[i].spec for i in timed)
        observers = list(self.observers)
        for i, obs in zip(timed, fresh, strict=True):
            observers[i] = obs
        self._suspended.difference_update(found)
        self.observers = tuple(observers)
        self._index()
        return [a for i in kept for a in self.observers[i].spec.atoms]

    def retime(self, topic: str) -> int:
        """The frequency observers of ``topic`` start afresh, their windows empty: its
        messages come another way from now on (rac.runtime.topic_statistics), and the two
        ways' arrivals in one window would be one window's mean of neither.  Their last
        verdicts stand until they give one again (after their first window).  How many."""
        found = [
            i
            for i in self._topics.get(topic, ())
            if i not in self._suspended and isinstance(self.observers[i], GObs)
        ]
        fresh = build_all(self.observers[i].spec for i in found)
        observers = list(self.observers)
        for i, obs in zip(found, fresh, strict=True):
            observers[i] = obs
        self.observers = tuple(observers)
        self._index()
        return len(found)

    def suspended(self, topic: str) -> bool:
        return any(i in self._suspended for i in self._readers(topic))

    def topic_fields(self) -> dict[str, frozenset[str]]:
        """Topic -> the fields some observer reads (empty: only the occurrence counts)."""
        return dict(self._fields)

    def feed(self, event: Event) -> list[Verdict]:
        if not math.isfinite(event.t):
            return []  # no time: the observers' windows and grids need one
        if isinstance(event, Message):
            targets = self._topics.get(event.topic, [])
        elif isinstance(event, NodeSample):
            targets = self._nodes.get(plain_node(event.node), [])
        elif isinstance(event, PropertySample):
            targets = self._properties.get((plain_node(event.node), event.prop), [])
        elif isinstance(event, DeviceStatus):
            targets = self._devices
        elif isinstance(event, ChannelState):
            targets = self._channels.get(event.channel, [])
        else:
            targets = []
        out: list[Verdict] = []
        suspended = self._suspended
        for i in targets:
            if i not in suspended:
                out.extend(_ordered(self.observers[i].feed(event)))
        return out

    def feed_messages(
        self,
        t: float,
        topic: str,
        count: int,
        stamps: Sequence[float | None] = (),
        values: Sequence[Mapping[str, float]] = (),
        seqs: Sequence[int | None] = (),
    ) -> list[Verdict]:
        """``count`` messages of ``topic`` received at ``t`` in one batch, in order: each
        observer gives the verdicts it would if each were fed as a :class:`Message`
        (``stamps`` and ``values`` give each one's stamp and fields, or are empty: none),
        routed once for the batch; a frequency observer takes them without a Message."""
        out: list[Verdict] = []
        if not math.isfinite(t) or count <= 0:
            return out
        suspended = self._suspended
        targets = [self.observers[i] for i in self._topics.get(topic, ()) if i not in suspended]
        # A frequency observer takes the occurrences as they are; the others Messages.
        for obs in targets:
            if isinstance(obs, GObs):
                for k in range(count):
                    changed = obs.occur(t, stamps[k] if stamps else None, seqs[k] if seqs else None)
                    if changed:
                        out.extend(changed)
        others = [o for o in targets if not isinstance(o, GObs)]
        for k in range(count if others else 0):
            message = Message(
                t,
                topic,
                values[k] if values else _NO_VALUES,
                stamps[k] if stamps else None,
                seqs[k] if seqs else None,
            )
            for obs in others:
                changed = obs.feed(message)
                if changed:
                    out.extend(_ordered(changed))
        return out

    def advance(self, t: float) -> list[Verdict]:
        out: list[Verdict] = []
        if not math.isfinite(t):
            return out
        for obs in self._timed:
            changed = obs.advance(t)
            if changed:
                out.extend(_ordered(changed))
        return out

    def starved(self, t: float, starved: bool) -> list[Verdict]:
        """The process feeding the bank is (or is no longer) starved from ``t`` on: the
        observers that judge time hold their negative verdicts (TimingObserver)."""
        out: list[Verdict] = []
        if not math.isfinite(t):
            return out
        for obs in self._timing:
            out.extend(_ordered(obs.starved(t, starved)))
        return out


def _add(index: dict[K, list[int]], key: K, i: int) -> None:
    slots = index.setdefault(key, [])
    if not slots or slots[-1] != i:
        slots.append(i)


def _ordered(verdicts: list[Verdict]) -> list[Verdict]:
    return sorted(verdicts, key=lambda v: v.atom) if len(verdicts) > 1 else verdicts
