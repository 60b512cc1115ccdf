"""NObs, the node observer (Algorithm 2): running(node).

Parameters: ``node`` (as in the model; a leading '/' is ignored), ``mismatch_th`` θ
(default 5).  One check per :class:`NodeSample` of the node, made by whoever captures the
computation graph (lines 3-4); the θ rule of :mod:`rac.observe.base` gives the verdict.
"""

from __future__ import annotations

from typing import ClassVar

from rac.observe.base import Latch, Mismatch, Needs, plain_node
from rac.observe.events import Event, NodeSample, Verdict
from rac.observe.params import Params
from rac.passes.observers import DEFAULT_MISMATCH_THRESHOLD, ObserverSpec


class NObs:
    timed: ClassVar[bool] = False  # a verdict changes only with an input

    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.node = plain_node(p.text("node"))
        self.needs = Needs(nodes=(self.node,))
        self._mismatch = Mismatch(p.count("mismatch_th", DEFAULT_MISMATCH_THRESHOLD))
        self._latch = Latch(p.atom())

    def feed(self, event: Event) -> list[Verdict]:
        out: list[Verdict] = []
        if isinstance(event, NodeSample) and plain_node(event.node) == self.node:
            self._latch.report(event.t, self._mismatch.check(event.running), out)
        return out

    def advance(self, t: float) -> list[Verdict]:
        return []
