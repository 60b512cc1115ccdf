"""QObs, the qualitative trend of one signal (Algorithm 4 as the errata reads it).

QObs is not an observer of its own in the model: BiQObs runs two of them.  It classifies
trends exactly as ``racc learn`` does (:mod:`rac.learn.trends`), so that a relation learned
from a recording holds at run time:

- β, the slope of a sample, is the least-squares slope (Equation 5.4, errata)
  β = (nΣtv − ΣtΣv)/(nΣt² − (Σt)²) over the samples within ±ω/2 of it; the window belongs
  to its middle sample.  The second and third derivatives are the same regression over the
  slopes, and over those again, with the same window.
- inc when β > β_p, dec when β < β_n; otherwise cons when the second and third derivatives
  both lie in (β_n, β_p), else the previous trend (cons when there is none, as the learner
  fills its leading undecided samples).
- The integrated side I(f) replaces each value by the running sum of the field's samples
  since the observer started (the learner's ``np.cumsum``); slopes do not see the offset.
- β_p = ``slope`` and β_n = −``slope`` when the spec gives a slope; otherwise they are
  estimated online as the learner defines them: β_p is the median of the positive slopes,
  β_n the median of the negative ones, over the last :data:`HISTORY` slopes, and ±∞ when
  there are none of that sign.  No trend is given before :data:`MIN_SLOPES` slopes.

Timing: a slope is known once a sample beyond its window's end has come, and each of the
three regressions waits for that, so the trend of the sample at time c is known about 3ω/2
(plus three sample intervals) after c.

Cost: O(1) amortised per sample.  Each regression keeps running sums over a deque of its
window; times and values are taken relative to an origin that moves to the newest sample
every :data:`REBASE_EVERY` samples, when the sums are recomputed exactly, so neither the
growing clock nor a growing integral cancels digits and additions leave no drift.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from enum import IntEnum


class Trend(IntEnum):
    """The learner's symbol codes (``rac.learn.trends``): -, 0, +."""

    DEC = 0
    CONS = 1
    INC = 2


HISTORY = 4096  # slopes kept for the online limits
MIN_SLOPES = 50  # slopes seen before the online limits give a trend
REBASE_EVERY = 1024


class SlidingSlope:
    """The least-squares slope of every sample over the samples within ±half of it."""

    __slots__ = (
        "_adds",
        "_centres",
        "_n",
        "_st",
        "_stt",
        "_stv",
        "_sv",
        "_svv",
        "_t0",
        "_v0",
        "_win",
        "half",
    )

    def __init__(self, half: float) -> None:
        self.half = half
        self._win: deque[tuple[float, float]] = deque()  # the samples (t, v) of the window
        self._centres: deque[float] = deque()  # sample times still waiting for their slope
        self._t0 = self._v0 = 0.0
        self._n = 0
        self._st = self._stt = self._sv = self._stv = self._svv = 0.0
        self._adds = 0

    def push(self, t: float, v: float) -> list[tuple[float, float]]:
        """Add a sample; return (time, slope) for every sample whose window it closes."""
        out = []
        while self._centres and t > self._centres[0] + self.half:
            centre = self._centres.popleft()
            low = centre - self.half
            while self._win[0][0] < low:
                self._remove(*self._win.popleft())
            out.append((centre, self._slope()))
        if self._adds >= REBASE_EVERY or not self._win:
            self._rebase(t, v)
        self._win.append((t, v))
        self._centres.append(t)
        self._add(t, v)
        return out

    def _add(self, t: float, v: float) -> None:
        x, y = t - self._t0, v - self._v0
        self._n += 1
        self._st += x
        self._stt += x * x
        self._sv += y
        self._stv += x * y
        self._svv += y * y
        self._adds += 1

    def _remove(self, t: float, v: float) -> None:
        x, y = t - self._t0, v - self._v0
        self._n -= 1
        self._st -= x
        self._stt -= x * x
        self._sv -= y
        self._stv -= x * y
        self._svv -= y * y

    def _rebase(self, t: float, v: float) -> None:
        self._t0, self._v0 = t, v
        self._n = 0
        self._st = self._stt = self._sv = self._stv = self._svv = 0.0
        for ts, vs in self._win:
            self._add(ts, vs)
        self._adds = 0

    def _slope(self) -> float:
        n = self._n
        den = n * self._stt - self._st * self._st
        if n < 2 or den <= 1e-12 * n * self._stt:
            return 0.0
        num = n * self._stv - self._st * self._sv
        # Running sums leave rounding residue where the signal is flat: that is no trend.
        if abs(num) <= 1e-10 * n * math.sqrt(self._stt * self._svv):
            return 0.0
        return num / den


class _Median:
    """The median of the positive (negative) numbers among the last ``size`` pushed."""

    def __init__(self, size: int) -> None:
        self._order: deque[float] = deque()
        self._size = size
        self.positive: list[float] = []  # sorted
        self.negative: list[float] = []  # sorted
        self.seen = 0

    def push(self, x: float) -> None:
        self.seen += 1
        self._order.append(x)
        self._insert(x)
        if len(self._order) > self._size:
            old = self._order.popleft()
            side = self.positive if old > 0 else self.negative if old < 0 else None
            if side is not None:
                del side[bisect.bisect_left(side, old)]

    def _insert(self, x: float) -> None:
        if x > 0:
            bisect.insort(self.positive, x)
        elif x < 0:
            bisect.insort(self.negative, x)

    @staticmethod
    def median(values: list[float], empty: float) -> float:
        n = len(values)
        if n == 0:
            return empty
        mid = n // 2
        return values[mid] if n % 2 else (values[mid - 1] + values[mid]) / 2


class QObs:
    """The trend of one field of one topic, raw or integrated."""

    def __init__(self, ws: float, integral: bool = False, slope: float | None = None) -> None:
        self.ws = ws
        self.integral = integral
        self.slope = slope
        half = ws / 2
        self._levels = (SlidingSlope(half), SlidingSlope(half), SlidingSlope(half))
        self._s1: deque[float] = deque()  # first and second derivatives waiting for the third
        self._s2: deque[float] = deque()
        self._limits = _Median(HISTORY)
        self._sum = 0.0
        self.latest: Trend | None = None  # Θ_p: the last trend given
        self.latest_t = math.nan  # the time that trend belongs to

    def limits(self) -> tuple[float, float] | None:
        """(β_n, β_p), or None while too few slopes have been seen to estimate them."""
        if self.slope is not None:
            return -self.slope, self.slope
        if self._limits.seen < MIN_SLOPES:
            return None
        m = self._limits
        return m.median(m.negative, -math.inf), m.median(m.positive, math.inf)

    def push(self, t: float, v: float) -> list[tuple[float, Trend]]:
        """Add a sample of the field; return the trends it decides, (time, trend) in order."""
        if self.integral:
            self._sum += v
            v = self._sum
        l1, l2, l3 = self._levels
        out = []
        for c1, s1 in l1.push(t, v):
            self._s1.append(s1)
            self._limits.push(s1)
            for c2, s2 in l2.push(c1, s1):
                self._s2.append(s2)
                for c3, s3 in l3.push(c2, s2):
                    trend = self._classify(self._s1.popleft(), self._s2.popleft(), s3)
                    if trend is not None:
                        self.latest, self.latest_t = trend, c3
                        out.append((c3, trend))
        return out

    def _classify(self, s1: float, s2: float, s3: float) -> Trend | None:
        limits = self.limits()
        if limits is None:
            return None
        low, high = limits
        if s1 > high:
            return Trend.INC
        if s1 < low:
            return Trend.DEC
        if low < s2 < high and low < s3 < high:
            return Trend.CONS
        return self.latest if self.latest is not None else Trend.CONS
