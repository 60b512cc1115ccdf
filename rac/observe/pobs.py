"""PObs, the property observer (Algorithm 7): ok(node, cpu|mem).

Parameters: ``node``, ``property`` (``cpu`` in percent of one core or ``mem`` in bytes),
``max_val`` v_max, ``mismatch_th`` θ (default 5).

One check per :class:`PropertySample`: the sample enters a circular queue of n = 10 values
that starts as zeros (line 1) and the check is mean(queue) ≤ v_max.  The zeros only pull the
mean down, so during the first n samples an overload shows late rather than early (§5.2.7
says the fill-up is tolerated by θ; the samples' rate is the runtime's choice, 10 Hz in the
text).  A sample that is not finite is no measurement and is skipped, as a message's
non-finite field is: in the queue it would spoil the mean for the next n checks.
"""

from __future__ import annotations

import math
from collections import deque
from typing import ClassVar

from rac.observe.base import Latch, Mismatch, Needs, plain_node
from rac.observe.events import Event, PropertySample, Verdict
from rac.observe.params import Params, spec_error
from rac.passes.observers import DEFAULT_MISMATCH_THRESHOLD, ObserverSpec

QUEUE_SIZE = 10
PROPERTIES = ("cpu", "mem")


class PObs:
    timed: ClassVar[bool] = False  # a verdict changes only with an input

    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.node = plain_node(p.text("node"))
        self.prop = p.text("property")
        if self.prop not in PROPERTIES:
            raise spec_error(spec, f"property must be cpu or mem, not {self.prop!r}", "RAC051")
        self.max_val = p.number("max_val")
        self.needs = Needs(properties=((self.node, self.prop),))
        self._queue: deque[float] = deque([0.0] * QUEUE_SIZE, maxlen=QUEUE_SIZE)
        self._mismatch = Mismatch(p.count("mismatch_th", DEFAULT_MISMATCH_THRESHOLD))
        self._latch = Latch(p.atom())

    def feed(self, event: Event) -> list[Verdict]:
        out: list[Verdict] = []
        if (
            isinstance(event, PropertySample)
            and event.prop == self.prop
            and plain_node(event.node) == self.node
            and math.isfinite(event.value)
        ):
            self._queue.append(event.value)  # the full deque drops its oldest (line 4)
            mean = sum(self._queue) / QUEUE_SIZE
            self._latch.report(event.t, self._mismatch.check(mean <= self.max_val), out)
        return out

    def advance(self, t: float) -> list[Verdict]:
        return []
