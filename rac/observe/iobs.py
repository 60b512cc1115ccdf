"""IObs, the interval observer (Algorithm 8): equal(t1, f1, t2, f2).

Parameters: ``topic1``, ``field1``, ``topic2``, ``field2``, ``max_diff`` Δ,
``mismatch_th`` θ (default 5).

The text reads both values in a loop (lines 3-4) without saying when.  We check at every
message of either topic that carries its field, once both values are known, against the
latest value of the other side: |v1 − v2| ≤ Δ.  A message that carries both fields (one
topic) is one check.  Missing or non-finite values are skipped.

The bound is that of the decimal numbers the model and the messages write: |v1 − v2| ≤ Δ up
to two units in the last place of the largest of the three (1.1 − 1.0 is
0.10000000000000009 in binary floating point, yet within Δ = 0.1).

A value beyond its field's plausible magnitude (:mod:`rac.observe.plausible`) is a failed
check, and is not kept as the side's latest value: it counts once against the pair and
leaves nothing behind for the next message.
"""

from __future__ import annotations

import math
from typing import ClassVar

from rac.observe.base import Latch, Mismatch, Needs
from rac.observe.events import Event, Message, Verdict
from rac.observe.params import Params
from rac.observe.plausible import bound, plausible
from rac.passes.observers import DEFAULT_MISMATCH_THRESHOLD, ObserverSpec


def field_value(message: Message, field: str) -> float | None:
    """The field's value, or None when the message does not carry a usable one."""
    value = message.values.get(field)
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def within(v1: float, v2: float, bound: float) -> bool:
    """|v1 − v2| ≤ bound, up to the rounding of the three decimal readings."""
    slack = 2 * math.ulp(max(abs(v1), abs(v2), abs(bound)))
    return abs(v1 - v2) <= bound + slack


def pair_needs(t1: str, f1: str, t2: str, f2: str) -> Needs:
    if t1 == t2:
        return Needs(topics=((t1, tuple(sorted({f1, f2}))),))
    return Needs(topics=((t1, (f1,)), (t2, (f2,))))


class IObs:
    timed: ClassVar[bool] = False  # a verdict changes only with an input

    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.topic1, self.field1 = p.text("topic1"), p.text("field1")
        self.topic2, self.field2 = p.text("topic2"), p.text("field2")
        self.max_diff = p.number("max_diff")
        self.needs = pair_needs(self.topic1, self.field1, self.topic2, self.field2)
        self._v1: float | None = None
        self._v2: float | None = None
        self._mismatch = Mismatch(p.count("mismatch_th", DEFAULT_MISMATCH_THRESHOLD))
        self._latch = Latch(p.atom())
        self._limit1, self._limit2 = bound(self.field1), bound(self.field2)

    def feed(self, event: Event) -> list[Verdict]:
        out: list[Verdict] = []
        if not isinstance(event, Message):
            return out
        fresh = glitch = False
        if event.topic == self.topic1 and (v := field_value(event, self.field1)) is not None:
            if plausible(v, self._limit1):
                self._v1, fresh = v, True
            else:
                glitch = True
        if event.topic == self.topic2 and (v := field_value(event, self.field2)) is not None:
            if plausible(v, self._limit2):
                self._v2, fresh = v, True
            else:
                glitch = True
        if glitch and self._latch.positive is not None:
            self._latch.report(event.t, self._mismatch.check(False), out)
        elif fresh and self._v1 is not None and self._v2 is not None:
            good = within(self._v1, self._v2, self.max_diff)
            self._latch.report(event.t, self._mismatch.check(good), out)
        return out

    def advance(self, t: float) -> list[Verdict]:
        return []
