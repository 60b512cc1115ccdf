"""Qualitative trends of signals (Algorithm 17, lines 1-14; Algorithm 4 as the errata reads it).

Every sample gets the slope of a linear regression over the samples within ±ws/2 of it,
with ws = C·median(Δ) so that a window holds about C occurrences.  b+ and b- are the
medians of the positive and negative slopes; a slope above b+ is increasing, below b- is
decreasing; otherwise the trend is constant when the second and third derivatives (the
same regression applied to the slopes, and again) also lie within (b-, b+), and holds the
previous trend when they do not.  All signals of one topic share its times, so the whole
field matrix is done at once with cumulative sums.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from rac.learn.fields import FloatArray
from rac.learn.recording import TopicData

DECREASING, CONSTANT, INCREASING = 0, 1, 2  # symbol codes: -, 0, +
SYMBOLS = "-0+"
Codes = npt.NDArray[np.int8]


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
    window_s: float


def window_bounds(
    times: FloatArray, half: float
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    lo = np.searchsorted(times, times - half, side="left")
    hi = np.searchsorted(times, times + half, side="right")
    return lo, hi


def windowed_slopes(
    times: FloatArray, values: FloatArray, lo: npt.NDArray[np.intp], hi: npt.NDArray[np.intp]
) -> FloatArray:
    """Least-squares slope per sample and row over the window [lo, hi) (Equation 5.4)."""
    t = times - times[0]
    v = values - values.mean(axis=1, keepdims=True)

    def window(x: FloatArray) -> FloatArray:
        c = np.concatenate([np.zeros((*x.shape[:-1], 1)), np.cumsum(x, axis=-1)], axis=-1)
        out: FloatArray = c[..., hi] - c[..., lo]
        return out

    n = (hi - lo).astype(np.float64)
    st, stt = window(t), window(t * t)
    sv, stv = window(v), window(v * t)
    den = n * stt - st * st
    num = n * stv - st * sv
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(den > 1e-12 * np.maximum(n * stt, 1e-300), num / den, 0.0)
    # Cumulative sums leave rounding residue where a signal is flat: that is no trend.
    span = np.ptp(values, axis=1, keepdims=True) / max(float(t[-1]), 1e-9)
    slope[np.abs(slope) <= 1e-9 * span] = 0.0
    return np.asarray(slope, dtype=np.float64)


def _median_limit(slopes: FloatArray, positive: bool) -> FloatArray:
    """Per row, the median of the positive (negative) slopes; ±inf when there are none."""
    chosen = np.where(slopes > 0 if positive else slopes < 0, slopes, np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows
        med = np.nanmedian(chosen, axis=1)
    fill = np.inf if positive else -np.inf
    return np.where(np.isnan(med), fill, med)[:, None]


def classify(s1: FloatArray, s2: FloatArray, s3: FloatArray) -> Codes:
    """The trend symbol per sample; undecided samples hold the previous symbol."""
    b_plus = _median_limit(s1, positive=True)
    b_minus = _median_limit(s1, positive=False)
    codes = np.full(s1.shape, -1, dtype=np.int8)
    flat = (b_minus < s2) & (s2 < b_plus) & (b_minus < s3) & (s3 < b_plus)
    codes[flat] = CONSTANT
    codes[s1 > b_plus] = INCREASING
    codes[s1 < b_minus] = DECREASING
    # Forward fill the undecided (-1) samples; leading ones count as constant.
    positions = np.arange(s1.shape[1])
    idx = np.where(codes >= 0, positions[None, :], 0)
    np.maximum.accumulate(idx, axis=1, out=idx)
    filled = np.take_along_axis(codes, idx, axis=1)
    filled[filled < 0] = CONSTANT
    return filled


def topic_trends(topic: TopicData, occurrences: int, integrate: bool = True) -> TopicTrends | None:
    """Trends of every non-constant field of ``topic`` and, with ``integrate``, of I(field).

    None when the topic has no usable signal (too few messages, or only constant fields).
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
    deltas = topic.intervals()
    median = float(np.median(deltas)) if deltas.size else 0.0
    if median <= 0:
        return None
    window = occurrences * median
    lo, hi = window_bounds(topic.times, window / 2)
    raw = values[usable]
    signals = [Signal(topic.name, topic.fields[i], False) for i in usable]
    rows = raw
    if integrate:
        rows = np.concatenate([raw, np.cumsum(raw, axis=1)])
        signals += [Signal(topic.name, topic.fields[i], True) for i in usable]
    s1 = windowed_slopes(topic.times, rows, lo, hi)
    s2 = windowed_slopes(topic.times, s1, lo, hi)
    s3 = windowed_slopes(topic.times, s2, lo, hi)
    return TopicTrends(topic.name, topic.times, tuple(signals), classify(s1, s2, s3), window)
