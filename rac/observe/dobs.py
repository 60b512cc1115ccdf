"""DObs, the diagnostic observer (Algorithm 3): ok(device).

Parameters: ``topic`` (``/diagnostics``), ``node`` (the nodes that report the device,
comma-separated; informative only), ``device``, ``mismatch_th`` θ (default 5).

One check per occurrence of ``/diagnostics`` that names the device (line 3 extracts one
state per occurrence): levels OK (0) and WARN (1) satisfy it (line 4), ERROR (2), STALE (3)
and any other level violate it.  A driver may report one device in several statuses of one
array ("hokuyo: Connection", "hokuyo: Frequency"); the device's state is then the worst of
them, so that an OK status does not cancel an ERROR one.  The statuses of one array are the
:class:`DeviceStatus` events of one time: a violation among them turns the array's check
into a violation however they are ordered (the verdict of the array's first statuses may
then be reported and revised at the same time, so the sources pass violations first).

Which statuses name the device (``extract_state`` is not spelled out): compared without
case and without a leading '/', the status's ``name`` or ``hardware_id`` equals the device,
or the name has the form ``<anything>: <device>`` or ``<device>: <anything>`` (the
``"<node>: <what>"`` names of ``diagnostic_updater``).  Other statuses are ignored.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import ClassVar

from rac.observe.base import Latch, Mismatch, Needs
from rac.observe.events import DeviceStatus, Event, Verdict
from rac.observe.params import Params
from rac.passes.observers import DEFAULT_MISMATCH_THRESHOLD, ObserverSpec

OK, WARN = 0, 1


def is_good(level: int) -> bool:
    """Does a status of this level satisfy the check (line 4)?"""
    return level in (OK, WARN)


def violations_first(statuses: Iterable[DeviceStatus]) -> list[DeviceStatus]:
    """The statuses of one array with the violating ones first (see the module docstring)."""
    return sorted(statuses, key=lambda s: is_good(s.level))


def _norm(text: str) -> str:
    return text.strip().lstrip("/").lower()


def names_device(status: DeviceStatus, device: str) -> bool:
    """Does ``status`` report ``device`` (see the module docstring)?"""
    dev = _norm(device)
    if dev in (_norm(status.name), _norm(status.hardware_id)):
        return True
    head, sep, tail = status.name.partition(":")
    while sep:
        if _norm(head) == dev or _norm(tail) == dev:
            return True
        # Names may hold more colons ("a: b: c"): try every split point.
        more_head, sep, tail = tail.partition(":")
        head = f"{head}:{more_head}"
    return False


class DObs:
    timed: ClassVar[bool] = False  # a verdict changes only with an input

    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.device = p.text("device")
        self.topic = p.text("topic", "/diagnostics")
        self.reporters = tuple(n.strip() for n in p.text("node", "").split(",") if n.strip())
        self.needs = Needs(devices=(self.device,))
        self._mismatch = Mismatch(p.count("mismatch_th", DEFAULT_MISMATCH_THRESHOLD))
        self._latch = Latch(p.atom())
        self._t = math.nan  # the time of the array being counted
        self._bad = False  # has it a violating status?
        self._before = 0  # the counter before its check

    def feed(self, event: Event) -> list[Verdict]:
        out: list[Verdict] = []
        if not isinstance(event, DeviceStatus) or not names_device(event, self.device):
            return out
        good = is_good(event.level)
        if event.t != self._t:
            self._t, self._bad, self._before = event.t, not good, self._mismatch.count
        elif good or self._bad:
            return out  # the array's check already counts a state at least this bad
        else:
            # The first violating status of an array counted as good: count it again, bad.
            self._bad = True
            self._mismatch.count = self._before
        self._latch.report(event.t, self._mismatch.check(good), out)
        return out

    def advance(self, t: float) -> list[Verdict]:
        return []
