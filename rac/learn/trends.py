"""Qualitative trends of signals (Algorithm 17, lines 1-14; Algorithm 4 as the errata reads it),
with the limits the running observer uses (:mod:`rac.observe.qobs`).

Every sample gets the slope β of a linear regression over the samples within ±ws/2 of it,
and the standard error se of that slope.  The window is the observer's: ws = C·median(Δ),
at least :data:`~rac.passes.observers.MIN_PAIR_WINDOW_S` (a relation's observer never
regresses over less than a second, so learning over a fifth of one, at 50 Hz, judged noise
the observer never sees).  A sample's limit is the largest of

- three standard errors of its slope (a slope the regression cannot tell from zero),
- 5 % of the signal's fast slopes (the 95th percentile of |β|): creep and the random walk of
  an integrated noisy rate, and
- the signal's **noise band**, measured where the signal rests: :data:`NOISE_K` times the
  quietest quarter of its slopes (the 25th percentile of |β|), at most :data:`NOISE_CAP` of
  its fast slopes.  An IMU heading that wanders by magnetometer noise while the robot stands
  still wanders within this band; odometry at rest is flat.

Above the limit a sample is increasing (+), below its negative decreasing (−); within it
constant (0) when the second and third derivatives (the same regression over the slopes,
and again) are within it too, else the previous symbol holds.  A sample **rests** when
|β| is within its limit: a relation gives no verdict while both of its sides rest, so a
robot standing still breaks no true relation (:mod:`rac.learn.correlate`; the observer
does the same).

This departs from the dissertation's b+ and b− (the medians of the positive and negative
slopes of a whole recording): on a robot that rests half of the time the medians are the
noise, and noise read as a trend fails every true relation at rest.  All signals of one
topic share its times, so the whole field matrix is done at once with cumulative sums.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from rac.learn.fields import FloatArray
from rac.learn.recording import TopicData
from rac.observe.noise import noise_band as observed_band
from rac.observe.qobs import FLOOR_FRACTION, FLOOR_QUANTILE, SIGNIFICANCE
from rac.passes.observers import MIN_PAIR_WINDOW_S

DECREASING, CONSTANT, INCREASING = 0, 1, 2  # symbol codes: -, 0, +
SYMBOLS = "-0+"
Codes = npt.NDArray[np.int8]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class Signal:
    """One row of a topic's trend matrix: a field, raw or integrated (I(M), Algorithm 16)."""

    topic: str
    field: str
    integrated: bool

    @property
    def text(self) -> str:
        ref = f"{self.topic}.{self.field}"
        return f"I({ref})" if self.integrated else ref


@dataclass(frozen=True, slots=True)
class TopicTrends:
    topic: str
    times: FloatArray
    signals: tuple[Signal, ...]
    codes: Codes  # shape (len(signals), len(times))
    rest: BoolArray  # same shape: |β| within the sample's limit
    window_s: float
    bands: FloatArray  # per signal: its noise band (a slope, units per second)
    floors: FloatArray  # per signal: the floor of its limits (5 % of its fast slopes)

    def row(self, signal: Signal) -> int | None:
        try:
            return self.signals.index(signal)
        except ValueError:
            return None


def window_bounds(
    times: FloatArray, half: float
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    lo = np.searchsorted(times, times - half, side="left")
    hi = np.searchsorted(times, times + half, side="right")
    return lo, hi


def windowed_slopes(
    times: FloatArray, values: FloatArray, lo: npt.NDArray[np.intp], hi: npt.NDArray[np.intp]
) -> tuple[FloatArray, FloatArray]:
    """Least-squares slope per sample and row over the window [lo, hi) (Equation 5.4), and
    its standard error from the residuals, √(SSR/(n−2)/Sxx) (0 where it is undefined)."""
    t = times - times[0]
    v = values - values.mean(axis=1, keepdims=True)

    def window(x: FloatArray) -> FloatArray:
        c = np.concatenate([np.zeros((*x.shape[:-1], 1)), np.cumsum(x, axis=-1)], axis=-1)
        out: FloatArray = c[..., hi] - c[..., lo]
        return out

    n = (hi - lo).astype(np.float64)
    st, stt = window(t), window(t * t)
    sv, stv, svv = window(v), window(v * t), window(v * v)
    den = n * stt - st * st
    num = n * stv - st * sv
    valid = den > 1e-12 * np.maximum(n * stt, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(valid, num / den, 0.0)
        syy = n * svv - sv * sv
        ssr = np.maximum(syy - slope * num, 0.0) / np.maximum(n, 1.0)
        se = np.where(valid & (n > 2), np.sqrt(ssr / np.maximum(n - 2, 1.0) / (den / n)), 0.0)
    # Cumulative sums leave rounding residue where a signal is flat: that is no trend.
    span = np.ptp(values, axis=1, keepdims=True) / max(float(t[-1]), 1e-9)
    flat = np.abs(slope) <= 1e-9 * span
    slope[flat] = 0.0
    se[flat] = 0.0
    return np.asarray(slope, dtype=np.float64), np.nan_to_num(np.asarray(se, dtype=np.float64))


def summed_error(
    times: FloatArray, values: FloatArray, lo: npt.NDArray[np.intp], hi: npt.NDArray[np.intp]
) -> FloatArray:
    """Per sample and row, the standard error of the slope of the running sum of ``values``
    over [lo, hi), from the scatter of the summed samples: se(mean)·n/span."""
    v = values - values.mean(axis=1, keepdims=True)
    c1 = np.concatenate([np.zeros((v.shape[0], 1)), np.cumsum(v, axis=1)], axis=1)
    c2 = np.concatenate([np.zeros((v.shape[0], 1)), np.cumsum(v * v, axis=1)], axis=1)
    n = (hi - lo).astype(np.float64)
    s1, s2 = c1[:, hi] - c1[:, lo], c2[:, hi] - c2[:, lo]
    span = times[np.maximum(hi - 1, lo)] - times[lo]
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = s1 / n
        variance = np.maximum(s2 / n - mean * mean, 0.0) * n / np.maximum(n - 1, 1.0)
        out = np.where((n >= 3) & (span > 0), np.sqrt(variance / n) * n / span, 0.0)
    return np.nan_to_num(np.asarray(out, dtype=np.float64))


def history(times: FloatArray, window: float) -> npt.NDArray[np.intp]:
    """The samples whose |β| the observer keeps: the first, then one per half window."""
    keep = [0]
    due = float(times[0]) + window / 2
    for i in np.searchsorted(
        times, times[0] + window / 2 * np.arange(1, 1 + int((times[-1] - times[0]) / (window / 2)))
    ).tolist():
        if i < times.size and times[i] >= due and i != keep[-1]:
            keep.append(i)
            due = float(times[i]) + window / 2
    return np.asarray(keep, dtype=np.intp)


def noise_band(slopes: FloatArray, kept: npt.NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
    """Per row: (the floor of its limits, its noise band), from |β| at ``kept`` samples."""
    magnitude = np.abs(slopes[:, kept])
    fast = np.quantile(magnitude, FLOOR_QUANTILE, axis=1)
    band = np.array(
        [observed_band(sorted(row.tolist()), f) for row, f in zip(magnitude, fast, strict=True)]
    )
    return FLOOR_FRACTION * fast, band


Scales = tuple[FloatArray, FloatArray]  # per signal: the floor and the noise band


def classify(s1: FloatArray, s2: FloatArray, s3: FloatArray, limit: FloatArray) -> Codes:
    """The trend symbol per sample; undecided samples hold the previous symbol."""
    codes = np.full(s1.shape, -1, dtype=np.int8)
    flat = (np.abs(s2) <= limit) & (np.abs(s3) <= limit)
    codes[flat] = CONSTANT
    codes[s1 > limit] = INCREASING
    codes[s1 < -limit] = DECREASING
    # Forward fill the undecided (-1) samples; leading ones count as constant.
    positions = np.arange(s1.shape[1])
    idx = np.where(codes >= 0, positions[None, :], 0)
    np.maximum.accumulate(idx, axis=1, out=idx)
    filled = np.take_along_axis(codes, idx, axis=1)
    filled[filled < 0] = CONSTANT
    return filled


def trend_window(topic: TopicData, occurrences: int) -> float | None:
    """The regression window of a topic: C·median(Δ), at least the observer's shortest."""
    deltas = topic.intervals()
    median = float(np.median(deltas)) if deltas.size else 0.0
    if not median > 0:
        return None
    return max(occurrences * median, MIN_PAIR_WINDOW_S)


def topic_trends(
    topic: TopicData,
    occurrences: int,
    integrate: bool = True,
    scales: dict[Signal, tuple[float, float]] | None = None,
) -> TopicTrends | None:
    """Trends of every non-constant field of ``topic`` and, with ``integrate``, of I(field).

    The floor and noise band of each signal come from ``topic`` itself, or from ``scales``
    where it has them: a block of a long recording is judged with the bands of the whole
    of it, as an observer that has run for a while has learned them.  None when the topic
    has no usable signal (too few messages, or only constant fields).
    """
    if topic.count < max(3, occurrences) or not topic.fields:
        return None
    values = topic.values
    usable = [
        i
        for i in range(len(topic.fields))
        if np.all(np.isfinite(values[i])) and np.ptp(values[i]) > 0
    ]
    if not usable:
        return None
    window = trend_window(topic, occurrences)
    if window is None:
        return None
    lo, hi = window_bounds(topic.times, window / 2)
    raw = values[usable]
    signals = [Signal(topic.name, topic.fields[i], False) for i in usable]
    rows = raw
    if integrate:
        rows = np.concatenate([raw, np.cumsum(raw, axis=1)])
        signals += [Signal(topic.name, topic.fields[i], True) for i in usable]
    s1, se = windowed_slopes(topic.times, rows, lo, hi)
    if integrate:
        # An integrated side's noise is judged on the samples it sums, as the observer
        # judges it (rac.observe.qobs.SlidingMean): a running sum of noise is a random walk
        # that its own residuals read as a trend.
        se[len(usable) :] = np.maximum(se[len(usable) :], summed_error(topic.times, raw, lo, hi))
    s2, _ = windowed_slopes(topic.times, s1, lo, hi)
    s3, _ = windowed_slopes(topic.times, s2, lo, hi)
    floors, bands = noise_band(s1, history(topic.times, window))
    for i, signal in enumerate(signals):
        if scales is not None and signal in scales:
            floors[i], bands[i] = scales[signal]
    limit = np.maximum(SIGNIFICANCE * se, np.maximum(floors, bands)[:, None])
    codes = classify(s1, s2, s3, limit)
    rest = np.abs(s1) <= limit
    return TopicTrends(topic.name, topic.times, tuple(signals), codes, rest, window, bands, floors)


def scales_of(trends: TopicTrends) -> dict[Signal, tuple[float, float]]:
    """Each signal's floor and noise band, to judge parts of its recording with."""
    return {
        s: (float(f), float(b))
        for s, f, b in zip(trends.signals, trends.floors, trends.bands, strict=True)
    }
