"""HObs, the hardware (board) observer (Algorithm 6): on(device) per power channel.

Parameters: ``topic`` (``/board_measurements``), ``channels`` (``jaguar:1,hokuyo:2``: each
device with its channel).  Every :class:`ChannelState` of a listed channel gives on(device)
or ¬on(device) at once: the board reads the channel's power directly, so there is no θ
(Algorithm 6 has none).  The publishing delay δ of the text is the runtime's sampling rate.
The atoms are the spec's, in the order of ``channels``.
"""

from __future__ import annotations

from typing import ClassVar

from rac.logic import Atom, mangle
from rac.observe.base import Latch, Needs
from rac.observe.events import ChannelState, Event, Verdict
from rac.observe.params import Params, spec_error
from rac.passes.observers import ObserverSpec


def parse_channels(spec: ObserverSpec, text: str) -> tuple[tuple[str, int], ...]:
    pairs = []
    for item in text.split(","):
        name, sep, number = item.strip().rpartition(":")
        if not sep or not name.strip() or not number.strip().isdigit():
            raise spec_error(
                spec, f"channels must read 'device:channel,...', not {text!r}", "RAC051"
            )
        pairs.append((name.strip(), int(number)))
    return tuple(pairs)


class HObs:
    timed: ClassVar[bool] = False  # a verdict changes only with an input

    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.topic = p.text("topic", "/board_measurements")
        self.channels = parse_channels(spec, p.text("channels"))
        atoms = spec.atoms
        if len(atoms) != len(self.channels):
            atoms = tuple(Atom("on", (mangle(name),)) for name, _ in self.channels)
        self._latches: dict[int, list[Latch]] = {}
        for (_, channel), atom in zip(self.channels, atoms, strict=True):
            self._latches.setdefault(channel, []).append(Latch(atom))
        self.needs = Needs(channels=tuple(sorted(self._latches)))

    def feed(self, event: Event) -> list[Verdict]:
        out: list[Verdict] = []
        if isinstance(event, ChannelState):
            for latch in self._latches.get(event.channel, ()):
                latch.report(event.t, event.on, out)
        return out

    def advance(self, t: float) -> list[Verdict]:
        return []
