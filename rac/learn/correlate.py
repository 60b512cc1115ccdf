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


_OUTSIDE = np.int8(3)  # no symbol: a time outside the other topic's span is not checked
_FLAT_TABLE = TABLE.reshape(-1)


def interpolate(times: npt.NDArray[np.float64], other: TopicTrends) -> tuple[Codes, int]:
    """``other``'s symbols at ``times`` by Table 9.1 (``_OUTSIDE`` beyond its span), and
    how many of the times lie inside it."""
    after = np.searchsorted(other.times, times, side="right")
    inside = (after > 0) & (after < other.times.size)
    before = np.clip(after - 1, 0, other.times.size - 2)
    t0 = other.times[before]
    t1 = other.times[before + 1]
    # a time inside the span falls strictly between t0 and t1; outside it (overwritten below)
    # the clipped pair may be two messages of one stamp, whose span of 0 would warn
    span = t1 - t0
    frac = (times - t0) / np.where(span > 0, span, 1.0)
    zone = np.searchsorted(_ZONE_EDGES, frac, side="right")
    # TABLE[s(q-), s(q+), zone] through one flat index.
    index = (other.codes[:, before].astype(np.intp) * 3 + other.codes[:, before + 1]) * 4 + zone
    codes = _FLAT_TABLE[index]
    codes[:, ~inside] = _OUTSIDE
    return codes, int(inside.sum())


Packed = tuple[npt.NDArray[np.uint64], ...]  # per symbol: rows of bits, 64 to a word


def pack(codes: Codes) -> Packed:
    """Where each row holds each symbol, as bits packed 64 to a word."""
    out = []
    for symbol in (_D, _C, _I):
        packed = np.packbits(codes == symbol, axis=1)
        pad = -packed.shape[1] % 8
        if pad:
            packed = np.pad(packed, ((0, 0), (0, pad)))
        out.append(np.ascontiguousarray(packed).view(np.uint64))
    return tuple(out)


def _matches(a: Packed, b: Packed) -> npt.NDArray[np.int64]:
    """(rows of a, rows of b): at how many positions the two rows hold the same symbol.

    Popcounts of packed bits are exact and need no BLAS (whose threads thrash on small
    shared machines).
    """
    total = np.zeros((a[0].shape[0], b[0].shape[0]), dtype=np.int64)
    for pa, pb in zip(a, b, strict=True):
        for r in range(pa.shape[0]):
            total[r] += np.bitwise_count(pa[r] & pb).sum(axis=1, dtype=np.int64)
    return total


def pair_matches(
    x: TopicTrends, y: TopicTrends, packed: dict[str, Packed] | None = None
) -> tuple[npt.NDArray[np.int64], int]:
    """Matches of every signal of ``x`` with every signal of ``y`` (both directions), checks.

    ``packed`` caches each topic's own packed symbols across topic pairs.
    """
    cache = packed if packed is not None else {}
    for t in (x, y):
        if t.topic not in cache:
            cache[t.topic] = pack(t.codes)
    if x.topic == y.topic:
        own = cache[x.topic]
        return 2 * _matches(own, own), 2 * x.times.size
    y_at_x, x_checks = interpolate(x.times, y)
    x_at_y, y_checks = interpolate(y.times, x)
    m = _matches(cache[x.topic], pack(y_at_x)) + _matches(pack(x_at_y), cache[y.topic])
    return m, x_checks + y_checks


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
    packed: dict[str, Packed] = {}
    for i, x in enumerate(ordered):
        for y in ordered[i:]:
            m, checks = pair_matches(x, y, packed)
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
