"""BiQObs, the binary qualitative observer (Algorithm 5): matched(t1, f1, t2, f2).

Parameters: ``topic1``, ``field1``, ``topic2``, ``field2``, ``mismatch_th`` θ (default 5);
``integral1``/``integral2`` (default false: that side is I(field), the running sum);
``ws`` ω (default 1.0 s), the regression window of both sides; ``slope1``/``slope2``
(optional: β_p = slope, β_n = −slope for that side, else the online limits of
:mod:`rac.observe.qobs`).

Each side is a :class:`~rac.observe.qobs.QObs` over its field.  The text's loop (lines 2-17)
has no cadence; we check every ω/2 on a fixed grid that starts at the first time the
observer sees (a ``feed`` or an ``advance``).  Grid instants up to an event's time are
checked before the event is applied.  No check is made until both sides have a trend, so
nothing is reported before.  The text gives each side its own window (ω₁, ω₂); the model
gives one, used by both.

A check compares the two sides' trends at the same time, not their latest ones (line 5):
a side's trend lags its samples by about 3ω/2 plus three sample intervals, so two topics at
different rates lag differently, and comparing the latest trends would see every turn as a
brief mismatch.  The side whose latest trend is later is taken back (``QObs.at``) to the
time of the other side's latest trend.  The check is satisfied when either side admits the
other's trend (:meth:`~rac.observe.qobs.TrendAt.admits`): equal, or its slope within a
factor of two of the limit between the two.  Without that tolerance two healthy signals
that turn at a rate close to a limit flip between "increasing" and "constant"
independently and read as a sustained mismatch; a real divergence (one side clearly rising
while the other is clearly flat or falling) still counts under the θ rule.

While both sides rest (each slope within its limit, :attr:`~rac.observe.qobs.TrendAt.rests`)
a check gives no verdict either way: it neither counts a match nor a mismatch.  A robot
standing still has an IMU whose heading wanders and odometry whose heading does not; that
is noise on both, not a broken relation.  A side that rests compares as constant.  A
mismatch in which one side rests and the other moves before its history can tell its noise
from its motion (:attr:`~rac.observe.qobs.QObs.settled`) is not counted; a match is.

A value beyond its field's plausible magnitude (:mod:`rac.observe.plausible`: a glitch, a
stranger's message) is never added to a side's sums; every check within the window ω after
it counts as a mismatch, so that a publisher that keeps sending such values breaks the
relation, while a single one changes nothing (θ) and leaves nothing behind.

Slopes are taken over receive times, so a starved receiver's clumps bend them: while the
process feeding the observer is starved (:meth:`BiQObs.starved`), and for 3ω after (a trend
needs samples up to 3ω/2 on either side of its own), a mismatch is not counted; a match is.
"""

from __future__ import annotations

import math
from typing import ClassVar

from rac.observe.base import Latch, Mismatch
from rac.observe.events import Event, Message, Verdict
from rac.observe.iobs import field_value, pair_needs
from rac.observe.params import Params
from rac.observe.plausible import bound
from rac.observe.qobs import QObs, Trend, TrendAt
from rac.passes.observers import DEFAULT_MISMATCH_THRESHOLD, ObserverSpec

DEFAULT_WS = 1.0


def _constant_at_rest(state: TrendAt) -> TrendAt:
    """A sample whose slope is within its limit compares as constant: the trend Algorithm 4
    holds over it (the previous one, while its derivatives are outside the limit) is what
    noise makes of a signal at rest, not a motion."""
    if state.rests and state.trend != Trend.CONS:
        return TrendAt(state.t, Trend.CONS, state.slope, state.limit)
    return state


class BiQObs:
    timed: ClassVar[bool] = True  # silence, windows and hysteresis run on time alone

    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.topic1, self.field1 = p.text("topic1"), p.text("field1")
        self.topic2, self.field2 = p.text("topic2"), p.text("field2")
        self.ws = p.positive("ws", DEFAULT_WS)
        slope1 = None if p.optional_number("slope1") is None else p.positive("slope1")
        slope2 = None if p.optional_number("slope2") is None else p.positive("slope2")
        self.side1 = QObs(self.ws, p.flag("integral1"), slope1)
        self.side2 = QObs(self.ws, p.flag("integral2"), slope2)
        self.side1.limit_abs, self.side2.limit_abs = bound(self.field1), bound(self.field2)
        self.needs = pair_needs(self.topic1, self.field1, self.topic2, self.field2)
        self._step = self.ws / 2
        self._next = math.nan  # the next grid instant
        self._mismatch = Mismatch(p.count("mismatch_th", DEFAULT_MISMATCH_THRESHOLD))
        self._latch = Latch(p.atom())
        self._starved = False
        self._settled = -math.inf  # slopes are trusted again from here on

    def feed(self, event: Event) -> list[Verdict]:
        if not isinstance(event, Message):
            return []
        out = self.advance(event.t)
        if event.topic == self.topic1 and (v := field_value(event, self.field1)) is not None:
            self.side1.push(event.t, v)
        if event.topic == self.topic2 and (v := field_value(event, self.field2)) is not None:
            self.side2.push(event.t, v)
        return out

    def advance(self, t: float) -> list[Verdict]:
        out: list[Verdict] = []
        if math.isnan(self._next):
            self._next = t + self._step
        checks = 0
        while self._next <= t:
            # A refused value within the window is a violation once the pair is judged at
            # all, whether or not the sides still have trends of the same time.
            glitch = self._latch.positive is not None and (
                self.side1.implausible(self._next) or self.side2.implausible(self._next)
            )
            pair = None if glitch else self._aligned()
            # Without both trends, or once the counter can no longer move (the trends stay
            # as they are until the next event), the remaining instants change nothing.
            if (pair is None and not glitch) or checks > self._mismatch.cap:
                self._next += (math.floor((t - self._next) / self._step) + 1) * self._step
                break
            if pair is None:
                matched = doubt = False  # a refused value in the window: a violation
            else:
                a, b = pair
                if a.rests and b.rests:
                    # Neither side moves beyond its noise: the relation says nothing (a
                    # robot standing still neither confirms nor breaks it).
                    checks += 1
                    self._next += self._step
                    continue
                # A side that rests is constant, whatever trend its sample held.
                a, b = _constant_at_rest(a), _constant_at_rest(b)
                matched = a.admits(b.trend) or b.admits(a.trend)
                # A side that moves, beside one that rests, while its history cannot yet
                # tell its noise from motion may be moving by noise: such a mismatch is not
                # counted, as while starved.  Two sides that both move disagree for real.
                doubt = (not a.rests and not self.side1.settled and b.rests) or (
                    not b.rests and not self.side2.settled and a.rests
                )
            if matched or not (doubt or self._starved or self._next < self._settled):
                self._latch.report(self._next, self._mismatch.check(matched), out)
            checks += 1
            self._next += self._step
        return out

    def starved(self, t: float, starved: bool) -> list[Verdict]:
        if self._starved and not starved:
            self._settled = t + 3 * self.ws
        self._starved = starved
        return []

    def _aligned(self) -> tuple[TrendAt, TrendAt] | None:
        """Both sides' trends at the same time: the later of the two is taken back to the
        time of the other's latest trend (the two topics' trends lag by different amounts)."""
        t1, t2 = self.side1.latest_t, self.side2.latest_t
        if math.isnan(t1) or math.isnan(t2):
            return None
        when = min(t1, t2)
        a, b = self.side1.at(when), self.side2.at(when)
        if a is None or b is None:
            return None
        return a, b
