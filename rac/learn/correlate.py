"""Qualitative correlation of signal pairs (Algorithm 17, lines 15-32; Algorithm 16; Table 9.1).

Each trend of one signal is checked against the other signal's trend at the same time,
interpolated from its closest trends before and after by Table 9.1; the match ratio m/c
counts both directions.  All signals of one topic share its times, so one topic pair is
one batch: the other topic's symbols are interpolated for every signal at once and the
match counts of all signal pairs come from popcounts of bit-packed symbol masks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from rac.learn.trends import CONSTANT, DECREASING, INCREASING, Codes, Signal, TopicTrends

_D, _C, _I = DECREASING, CONSTANT, INCREASING
# TABLE[s(q-), s(q+), zone]: zones split [t(q-), t(q+)] at 1/3, 1/2 and 2/3 (Table 9.1).
TABLE = np.empty((3, 3, 4), dtype=np.int8)
TABLE[_D, _D] = (_D, _D, _D, _D)
TABLE[_D, _C] = (_D, _D, _C, _C)
TABLE[_D, _I] = (_D, _C, _C, _I)
TABLE[_C, _D] = (_C, _C, _D, _D)
TABLE[_C, _C] = (_C, _C, _C, _C)
TABLE[_C, _I] = (_C, _C, _I, _I)
TABLE[_I, _D] = (_I, _C, _C, _D)
TABLE[_I, _C] = (_I, _I, _C, _C)
TABLE[_I, _I] = (_I, _I, _I, _I)
_ZONE_EDGES = np.array([1 / 3, 1 / 2, 2 / 3])


@dataclass(frozen=True, slots=True)
class Correlation:
    """Two signals and how often their trends matched."""

    a: Signal
    b: Signal
    matches: int
    checks: int
    chance: float  # the ratio two independent signals with these trend frequencies reach

    @property
    def ratio(self) -> float:
        return self.matches / self.checks if self.checks else 0.0


def interpolate(
    times: npt.NDArray[np.float64], other: TopicTrends
) -> tuple[Codes, npt.NDArray[np.bool_]]:
    """``other``'s symbols at ``times`` by Table 9.1, and which times lie inside its span."""
    after = np.searchsorted(other.times, times, side="right")
    inside = (after > 0) & (after < other.times.size)
    before = after[inside] - 1
    t0 = other.times[before]
    t1 = other.times[before + 1]
    frac = (times[inside] - t0) / (t1 - t0)
    zone = np.searchsorted(_ZONE_EDGES, frac, side="right")
    codes = TABLE[other.codes[:, before], other.codes[:, before + 1], zone]
    return codes, inside


def _matches(a: Codes, b: Codes) -> npt.NDArray[np.int64]:
    """(rows of a, rows of b): at how many positions the two rows hold the same symbol.

    Each symbol's occurrences are packed eight to a byte and counted with popcount, which
    is exact and needs no BLAS (whose threads thrash on small shared machines).
    """
    total = np.zeros((a.shape[0], b.shape[0]), dtype=np.int64)
    for symbol in (_D, _C, _I):
        pa = np.packbits(a == symbol, axis=1)
        pb = np.packbits(b == symbol, axis=1)
        total += np.bitwise_count(pa[:, None, :] & pb[None, :, :]).sum(axis=2, dtype=np.int64)
    return total


def pair_matches(x: TopicTrends, y: TopicTrends) -> tuple[npt.NDArray[np.int64], int]:
    """Matches of every signal of ``x`` with every signal of ``y`` (both directions), checks."""
    if x.topic == y.topic:
        return 2 * _matches(x.codes, x.codes), 2 * x.times.size
    y_at_x, x_inside = interpolate(x.times, y)
    x_at_y, y_inside = interpolate(y.times, x)
    m = _matches(x.codes[:, x_inside], y_at_x) + _matches(x_at_y, y.codes[:, y_inside])
    return m, int(x_inside.sum() + y_inside.sum())


def _admissible(x: TopicTrends, y: TopicTrends) -> npt.NDArray[np.bool_]:
    """Algorithm 16: both raw or exactly one integrated; within a topic, each pair once and
    never a field with itself."""
    xi = np.array([s.integrated for s in x.signals])
    yi = np.array([s.integrated for s in y.signals])
    ok = ~(xi[:, None] & yi[None, :])
    if x.topic == y.topic:
        xf = np.array([s.field for s in x.signals])
        upper = np.triu(np.ones((xi.size, xi.size), dtype=bool), k=1)
        ok &= upper & (xf[:, None] != xf[None, :])
    out: npt.NDArray[np.bool_] = ok
    return out


def _frequencies(t: TopicTrends) -> npt.NDArray[np.float64]:
    """(signals, 3): how often each signal shows each symbol."""
    return np.stack([(t.codes == s).mean(axis=1) for s in (_D, _C, _I)], axis=1)


def correlations(trends: Sequence[TopicTrends], q: float, min_lift: float) -> list[Correlation]:
    """Every admissible signal pair whose match ratio exceeds ``q`` (Algorithm 17, line 32)
    and beats chance by ``min_lift``, over all topic pairs.

    Chance is Σ p₁(s)·p₂(s) over the symbols: two unrelated signals that are mostly
    constant, or mostly rising and falling at random, match that often by accident.
    """
    out: list[Correlation] = []
    ordered = sorted(trends, key=lambda t: t.topic)
    freqs = {t.topic: _frequencies(t) for t in ordered}
    for i, x in enumerate(ordered):
        for y in ordered[i:]:
            m, checks = pair_matches(x, y)
            if checks == 0:
                continue
            chance = freqs[x.topic] @ freqs[y.topic].T
            ratio = m / checks
            keep = _admissible(x, y) & (ratio > q) & (ratio >= chance + min_lift)
            rows, cols = np.nonzero(keep)
            for r, c in zip(rows.tolist(), cols.tolist(), strict=True):
                out.append(
                    Correlation(
                        x.signals[r], y.signals[c], int(m[r, c]), checks, float(chance[r, c])
                    )
                )
    return out
