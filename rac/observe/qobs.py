"""QObs, the qualitative trend of one signal (Algorithm 4 as the errata reads it).

QObs is not an observer of its own in the model: BiQObs runs two of them.

- β, the slope of a sample, is the least-squares slope (Equation 5.4, errata)
  β = (nΣtv − ΣtΣv)/(nΣt² − (Σt)²) over the samples within ±ω/2 of it; the window belongs
  to its middle sample.  The second and third derivatives are the same regression over the
  slopes, and over those again, with the same window.  Each regression also gives the
  standard error of its slope from its residuals, se = √(SSR/(n−2)/Sxx).
- inc when β > β_p, dec when β < β_n; otherwise cons when the second and third derivatives
  lie within [β_n, β_p], the slope's own limits (line 17 and the errata), else the previous
  trend (cons when there is none).  The bounds are included (line 17 has <): a perfectly
  flat signal has slopes and limits of 0 and must still read constant.
- The integrated side I(f) replaces each value by the running sum of the field's samples
  since the observer started (the learner's ``np.cumsum``); slopes do not see the offset.
- β_p = ``slope`` and β_n = −``slope`` when the spec gives a slope.  Otherwise, per sample,
  β_p = max(:data:`SIGNIFICANCE`·se, floor) with the se of the sample's slope, β_n = −β_p;
  the floor is the larger of :data:`FLOOR_FRACTION` of the :data:`FLOOR_QUANTILE` quantile
  of |β| over a history of |β| taken once per half window (the last :data:`HISTORY`) and
  the signal's noise band, the valley between its slopes at rest and in motion in that
  history (:func:`rac.observe.noise.noise_band`, at most a quarter of that quantile).
  No trend is given until the history holds :data:`MIN_HISTORY` entries (10 s at ω = 1 s).
- A trend **rests** while |β| is within its limit (:attr:`TrendAt.rests`): a BiQObs gives
  no verdict while both of its sides rest.  Until its history is :attr:`QObs.settled` (it
  has shown the signal at rest and moving, or is 20 s old: :func:`rac.observe.noise.settled`)
  a side cannot tell its noise from slow motion, and a BiQObs counts no mismatch in which it
  moves while the other side rests (a match still counts).
- An integrated side's slope error is at least that of the samples it sums
  (:class:`SlidingMean`): the running sum of a gyro's noise is a random walk.

This deviates from the learner (:mod:`rac.learn.trends`), whose β_p/β_n are the medians of
the positive/negative slopes of a whole recording.  A running observer has no recording,
and online medians failed on real-looking data: after a long still stretch they collapse to
the noise level, so noise reads as a trend, and they sit at the typical turn rate, so a
slip at a similar rate reads constant.  The significance test separates motion from noise;
the floor keeps random-walk drift (an integrated noisy rate) and sub-1 % creep from counting
as trends.

``recent`` keeps the :class:`TrendAt` (time, trend, β, β_p) of the last 2ω and ``at(t)``
looks one up, so that BiQObs can compare two sides at the same time;
:meth:`TrendAt.admits` is its tolerance rule (a slope within a factor :data:`MARGIN` of
the limit between two trends could be either).

Timing: a slope is known once a sample beyond its window's end has come, and each of the
three regressions waits for that, so the trend of the sample at time c is known about 3ω/2
(plus three sample intervals) after c.

Cost: O(1) amortised per sample.  Each regression keeps running sums over a deque of its
window; times and values are taken relative to an origin that moves to the newest sample
every :data:`REBASE_EVERY` samples, when the sums are recomputed exactly, so neither the
growing clock nor a growing integral cancels digits and additions leave no drift.

**No value poisons the sums** (a glitching driver, or a stranger's message).  A value that
is not finite, or beyond its field's plausible magnitude (:mod:`rac.observe.plausible`), is
never pushed: :meth:`QObs.push` refuses it and remembers when (:meth:`QObs.implausible`),
which BiQObs counts against the pair for one window.  Within the plausible range a value
can still dwarf the rest of its window (a spike of 1e9 among values near 1): subtracting it
from the running sums when it leaves would leave rounding residue of its own size, so a
sample that large leaving the window makes the sums be recomputed exactly, about the newest
sample (:meth:`SlidingSlope._remove`).  The integral's running sum is moved back to zero
(with the window's values, which leaves every slope as it was) whenever it grows past
:data:`RECENTRE_AT`, so that a large integral never swallows the increments that follow.
The observer is therefore exact again one window after any value.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass
from enum import IntEnum

from rac.observe.noise import noise_band, settled
from rac.observe.plausible import GENERIC_BOUND, plausible


class Trend(IntEnum):
    """The learner's symbol codes (``rac.learn.trends``): -, 0, +."""

    DEC = 0
    CONS = 1
    INC = 2


SIGNIFICANCE = 3.0  # a slope is a trend when it exceeds this many standard errors
FLOOR_FRACTION = 0.05  # ... and this fraction of the signal's typical fast slope
FLOOR_QUANTILE = 0.95  # the typical fast slope: this quantile of |β| over the history
HISTORY = 2000  # |β| samples kept, one per half window (about 17 minutes at ω = 1 s)
MIN_HISTORY = 20  # samples before the first trend (10 s at ω = 1 s)
MARGIN = 2.0  # how far from a limit a slope must lie to be clearly on one side of it
BAND_EVERY = 20  # the noise band is measured again after this many |β| join the history
REBASE_EVERY = 1024
# A sample whose squared distance from the origin exceeds this many times the mean of the
# rest of its window leaves the sums by an exact recomputation, not a subtraction.
RESUM_RATIO = 1e6
RECENTRE_AT = 1e6  # an integral's running sum beyond this is moved back to zero


class SlidingSlope:
    """The least-squares slope of every sample over the samples within ±half of it."""

    __slots__ = (
        "_adds",
        "_centres",
        "_n",
        "_st",
        "_stale",
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
        self._stale = False  # a sample too large to subtract left: recompute the sums

    def push(self, t: float, v: float) -> list[tuple[float, float, float]]:
        """Add a sample; return (time, slope, standard error of the slope) for every sample
        whose window it closes."""
        out = []
        while self._centres and t > self._centres[0] + self.half:
            centre = self._centres.popleft()
            low = centre - self.half
            while self._win[0][0] < low:
                self._remove(*self._win.popleft())
            if self._stale:
                self._rebase(*self._win[-1])
            out.append((centre, *self._slope()))
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
        # What the subtraction left is rounding residue of the removed sample's size: when
        # that sample dwarfs the rest of the window, the sums are recomputed instead.
        if y * y > RESUM_RATIO * abs(self._svv) / max(self._n, 1):
            self._stale = True

    def shift(self, dv: float) -> None:
        """Every value of the window less ``dv``: the slopes stay as they are (the sums are
        about an origin that moves with them), and the values become small again."""
        self._win = deque((t, v - dv) for t, v in self._win)
        self._v0 -= dv

    def _rebase(self, t: float, v: float) -> None:
        self._t0, self._v0 = t, v
        self._n = 0
        self._st = self._stt = self._sv = self._stv = self._svv = 0.0
        for ts, vs in self._win:
            self._add(ts, vs)
        self._adds = 0
        self._stale = False

    def _slope(self) -> tuple[float, float]:
        """The least-squares slope of the window and its standard error (0 when flat)."""
        n = self._n
        den = n * self._stt - self._st * self._st
        if n < 2 or den <= 1e-12 * n * self._stt:
            return 0.0, 0.0
        num = n * self._stv - self._st * self._sv
        # Running sums leave rounding residue where the signal is flat: that is no trend.
        if abs(num) <= 1e-10 * n * math.sqrt(max(self._stt * self._svv, 0.0)):
            return 0.0, 0.0
        slope = num / den
        if n < 3:
            return slope, 0.0
        # Residual sum of squares of the fit, from the same sums: n·SSR = n·Syy − β·num.
        syy = n * self._svv - self._sv * self._sv
        ssr = max(syy - slope * num, 0.0) / n
        return slope, math.sqrt(ssr / (n - 2) / (den / n))


class SlidingMean(SlidingSlope):
    """Over the same windows as a :class:`SlidingSlope` of a running sum, the slope that sum
    has from its raw samples' mean, mean·n/span, and its standard error from their scatter,
    se(mean)·n/span.  A running sum of noise is a random walk, which a regression over its
    own values reads as a trend its residuals cannot question; the scatter of the summed
    samples can (an integrated gyro of a robot standing still rises only by its noise)."""

    __slots__ = ()

    def _slope(self) -> tuple[float, float]:
        n = self._n
        if n < 3:
            return 0.0, 0.0
        span = self._win[-1][0] - self._win[0][0]
        if not span > 0:
            return 0.0, 0.0
        mean = self._sv / n
        variance = max(self._svv / n - mean * mean, 0.0) * n / (n - 1)
        scale = n / span
        return (mean + self._v0) * scale, math.sqrt(variance / n) * scale


class _Quantile:
    """A quantile of the last ``size`` numbers pushed (kept sorted; pushes are rare)."""

    def __init__(self, size: int, q: float) -> None:
        self._order: deque[float] = deque()
        self._sorted: list[float] = []
        self._size = size
        self._q = q

    def __len__(self) -> int:
        return len(self._order)

    def push(self, x: float) -> None:
        self._order.append(x)
        bisect.insort(self._sorted, x)
        if len(self._order) > self._size:
            del self._sorted[bisect.bisect_left(self._sorted, self._order.popleft())]

    def value(self) -> float:
        return self._sorted[min(len(self._sorted) - 1, int(self._q * len(self._sorted)))]

    def values(self) -> list[float]:
        """Every number kept, sorted."""
        return self._sorted


@dataclass(frozen=True, slots=True)
class TrendAt:
    """The trend of the sample at time ``t``, its slope β and limit β_p (β_n = −β_p)."""

    t: float
    trend: Trend
    slope: float
    limit: float

    @property
    def rests(self) -> bool:
        """Its slope is within its limit: the signal moves no more than its noise."""
        return abs(self.slope) <= self.limit

    def admits(self, trend: Trend) -> bool:
        """Could this trend as well have been ``trend``?  True when it is, or when the slope
        lies within a factor :data:`MARGIN` of the limit between the two: a slope just above
        β_p is as much constant as increasing (see BiQObs)."""
        if trend == self.trend:
            return True
        if trend == Trend.INC:
            return self.slope > self.limit / MARGIN
        if trend == Trend.DEC:
            return self.slope < -self.limit / MARGIN
        return abs(self.slope) <= self.limit * MARGIN


class QObs:
    """The trend of one field of one topic, raw or integrated."""

    def __init__(self, ws: float, integral: bool = False, slope: float | None = None) -> None:
        self.ws = ws
        self.integral = integral
        self.slope = slope
        half = ws / 2
        self._levels = (SlidingSlope(half), SlidingSlope(half), SlidingSlope(half))
        # An integrated side's noise is judged on the samples it sums (SlidingMean).
        self._raw = SlidingMean(half) if integral else None
        # First and second derivatives (value, standard error) waiting for the third.
        self._s1: deque[tuple[float, float]] = deque()
        self._s2: deque[float] = deque()
        self._sum = 0.0
        self._last_t = math.nan
        self.limit_abs = GENERIC_BOUND  # the field's plausible magnitude (BiQObs sets it)
        self.implausible_t = -math.inf  # when the last refused value came
        self.latest: Trend | None = None  # Θ_p: the last trend given
        self.latest_t = math.nan  # the time that trend belongs to
        self.latest_slope = math.nan  # β of that sample
        self.latest_limit = math.nan  # β_p of that sample (β_n = −β_p)
        self.recent: deque[TrendAt] = deque()  # the trends of the last 2ω, oldest first
        self._scale = _Quantile(HISTORY, FLOOR_QUANTILE)
        self._scale_due = -math.inf  # when the next |β| joins the history
        self._band = 0.0  # the noise band of the history (noise_band)
        self._band_due = 0  # history entries until it is measured again
        # The history tells noise from motion (noise.settled); a given slope needs none.
        self.settled = slope is not None

    def implausible(self, t: float) -> bool:
        """Whether a refused value came within the window ω before ``t``."""
        return t - self.implausible_t <= self.ws

    def floor(self) -> float | None:
        """The smallest limit: a fraction of the typical fast slope; None while unknown."""
        if len(self._scale) < MIN_HISTORY:
            return None
        return max(FLOOR_FRACTION * self._scale.value(), self._band)

    def limit(self, se: float, floor: float) -> float:
        """β_p for a slope with standard error ``se``: the given slope, else the larger of
        SIGNIFICANCE·se and the floor."""
        return self.slope if self.slope is not None else max(SIGNIFICANCE * se, floor)

    def limits(self) -> tuple[float, float] | None:
        """(β_n, β_p) of the latest trend, or None before the first."""
        if self.latest is None:
            return None
        return -self.latest_limit, self.latest_limit

    def at(self, t: float) -> TrendAt | None:
        """The trend of the last sample at or before ``t`` among the recent ones."""
        found = None
        for state in self.recent:
            if state.t > t:
                break
            found = state
        return found

    def push(self, t: float, v: float) -> list[tuple[float, Trend]]:
        """Add a sample of the field; return the trends it decides, (time, trend) in order.
        A sample at the time of the previous one is the same message, passed on by another
        relation sharing this trend: it is taken once."""
        if t == self._last_t:
            return []
        if not plausible(v, self.limit_abs):
            self.implausible_t = t  # evidence about the publisher, not a sample
            return []
        self._last_t = t
        raw = self._raw.push(t, v) if self._raw is not None else None
        if self.integral:
            self._sum += v
            if abs(self._sum) > RECENTRE_AT:
                self._levels[0].shift(self._sum)
                self._sum = 0.0
            v = self._sum
        l1, l2, l3 = self._levels
        out = []
        for k, (c1, s1, e1) in enumerate(l1.push(t, v)):
            if raw is not None:
                # The same windows close on both: the raw samples' scatter gives the error.
                e1 = max(e1, raw[k][2])
            if c1 >= self._scale_due:
                self._scale.push(abs(s1))
                self._scale_due = c1 + self.ws / 2
                # Measured again every BAND_EVERY entries (10 s at ω = 1 s), and at each of
                # the first MIN_HISTORY: a band moves slowly, a valley costs a histogram.
                self._band_due -= 1
                if self._band_due <= 0 or len(self._scale) <= MIN_HISTORY:
                    history = self._scale.values()
                    self._band = noise_band(history, self._scale.value())
                    self.settled = self.settled or settled(history)
                    self._band_due = BAND_EVERY
            self._s1.append((s1, e1))
            for c2, s2, _ in l2.push(c1, s1):
                self._s2.append(s2)
                for c3, s3, _ in l3.push(c2, s2):
                    slope, se = self._s1.popleft()
                    second = self._s2.popleft()
                    floor = self.floor()
                    if floor is None and self.slope is None:
                        continue
                    floor = floor or 0.0
                    high = self.limit(se, floor)
                    # Algorithm 4 holds the derivatives to the slope's own limits.
                    trend = self._classify(slope, high, second, high, s3, high)
                    self.latest, self.latest_t = trend, c3
                    self.latest_slope, self.latest_limit = slope, high
                    self.recent.append(TrendAt(c3, trend, slope, high))
                    while self.recent[0].t < c3 - 2 * self.ws:
                        self.recent.popleft()
                    out.append((c3, trend))
        return out

    def _classify(self, s1: float, l1: float, s2: float, l2: float, s3: float, l3: float) -> Trend:
        if s1 > l1:
            return Trend.INC
        if s1 < -l1:
            return Trend.DEC
        if -l2 <= s2 <= l2 and -l3 <= s3 <= l3:
            return Trend.CONS
        return self.latest if self.latest is not None else Trend.CONS
