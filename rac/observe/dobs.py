"""DObs, the diagnostic observer (Algorithm 3): ok(device).

Parameters: ``topic`` (``/diagnostics``), ``node`` (the nodes that report the device,
comma-separated; informative only), ``device``, ``mismatch_th`` θ (default 5).

One check per :class:`DeviceStatus` that names the device: levels OK (0) and WARN (1)
satisfy it (line 4), ERROR (2), STALE (3) and any other level violate it.

Which statuses name the device (``extract_state`` is not spelled out): compared without
case and without a leading '/', the status's ``name`` or ``hardware_id`` equals the device,
or the name has the form ``<anything>: <device>`` or ``<device>: <anything>`` (the
``"<node>: <what>"`` names of ``diagnostic_updater``).  Other statuses are ignored.
"""

from __future__ import annotations

from rac.observe.base import Latch, Mismatch, Needs
from rac.observe.events import DeviceStatus, Event, Verdict
from rac.observe.params import Params
from rac.passes.observers import DEFAULT_MISMATCH_THRESHOLD, ObserverSpec

OK, WARN = 0, 1


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
    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.device = p.text("device")
        self.topic = p.text("topic", "/diagnostics")
        self.reporters = tuple(n.strip() for n in p.text("node", "").split(",") if n.strip())
        self.needs = Needs(devices=(self.device,))
        self._mismatch = Mismatch(p.count("mismatch_th", DEFAULT_MISMATCH_THRESHOLD))
        self._latch = Latch(p.atom())

    def feed(self, event: Event) -> list[Verdict]:
        out: list[Verdict] = []
        if isinstance(event, DeviceStatus) and names_device(event, self.device):
            good = event.level in (OK, WARN)
            self._latch.report(event.t, self._mismatch.check(good), out)
        return out

    def advance(self, t: float) -> list[Verdict]:
        return []
