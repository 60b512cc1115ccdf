"""Qualitative correlation of signal pairs (Algorithm 17, lines 15-32; Table 9.1), and the
statistics of that agreement for autocorrelated series.

Each trend of one signal is checked against the other signal's trend at the same time,
interpolated from its closest trends before and after by Table 9.1; the match ratio m/c
counts both directions.  A sample that rests (its slope within its limit) compares as
constant, as the relation's observer compares it.  A check is counted only while at least
one side moves beyond its noise: while both rest (:mod:`rac.learn.trends`) the relation says
nothing, as its observer says nothing, so a robot standing still neither confirms nor
breaks it.

**Chance.**  Two independent signals agree by chance as often as their frequencies of
(symbol, rest) states say: c = Σ p₁(a)·p₂(b)·match(a, b) / Σ p₁(a)·p₂(b)·counted(a, b).

**Effective sample size.**  Successive checks are not independent: a trend holds for a run
of samples.  Under the null hypothesis (the two signals independent) the autocovariance of
u = match − c·counted at lag τ follows from each side's own state dynamics alone:
γ(τ) = Σ U ∘ (P₁(τ) U P₂(τ)ᵀ), where Pᵢ(τ) is signal i's joint frequency of states τ apart
and U = match − c·counted as a 6 × 6 matrix.  The variance of Σu is then N·(γ₀ + 2Σₖγₖ)
(summed while γ stays positive, Geyer's initial positive sequence), and the effective number
of independent checks is c(1 − c)·checks² / that variance.  A drifting signal (a trend that
holds for minutes) has few; a lively one many.  The two directions of a check are
correlated; their variances are combined as if they were perfectly so (the safe side).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from rac.learn.fields import FloatArray
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

_OUTSIDE = np.int8(3)  # no symbol: a time outside the other topic's span is not checked
_FLAT_TABLE = TABLE.reshape(-1)
STATES = 6  # symbol × rest: state = 2·symbol + rest
_REST = np.arange(STATES) % 2 == 1
# A resting sample compares as constant, whatever symbol Algorithm 4 held over it (as the
# relation's observer compares it).
_SYM = np.where(_REST, CONSTANT, np.arange(STATES) // 2)
COUNTED = ~(_REST[:, None] & _REST[None, :])  # [a, b]: not both at rest
MATCHED = COUNTED & (_SYM[:, None] == _SYM[None, :])
MAX_LAG_SHARE = 0.25  # autocovariances are summed up to this share of the span
LAG_GROWTH = 1.3  # the lag grid grows geometrically


def interpolate(times: FloatArray, other: TopicTrends) -> tuple[Codes, int]:
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


def states(trends: TopicTrends) -> npt.NDArray[np.int8]:
    """(signals, times): each sample's state, 2·symbol + rest."""
    out: npt.NDArray[np.int8] = (trends.codes * 2 + trends.rest).astype(np.int8)
    return out


def states_at(times: FloatArray, other: TopicTrends) -> tuple[npt.NDArray[np.int8], FloatArray]:
    """``other``'s states at ``times``: the symbol by Table 9.1, rest from its sample at or
    before each time; -1 outside its span.  Also the mask of the times inside."""
    codes, _ = interpolate(times, other)
    before = np.clip(np.searchsorted(other.times, times, side="right") - 1, 0, None)
    rest = other.rest[:, before]
    out = np.where(codes == _OUTSIDE, -1, codes.astype(np.int16) * 2 + rest).astype(np.int8)
    inside = (codes[0] != _OUTSIDE) if codes.shape[0] else np.zeros(times.size, dtype=bool)
    return out, inside.astype(np.float64)


def frequencies(st: npt.NDArray[np.int8]) -> FloatArray:
    """(rows, STATES): how often each row shows each state."""
    counts = np.stack([(st == s).sum(axis=1) for s in range(STATES)], axis=1).astype(np.float64)
    total = np.maximum(counts.sum(axis=1, keepdims=True), 1.0)
    out: FloatArray = counts / total
    return out


def chance(pa: FloatArray, pb: FloatArray) -> float:
    """The agreement of two independent signals with these state frequencies."""
    counted = float(pa @ COUNTED.astype(np.float64) @ pb)
    if counted <= 0:
        return 0.0
    return float(pa @ MATCHED.astype(np.float64) @ pb) / counted


@dataclass(frozen=True, slots=True)
class Lags:
    """One signal's joint frequencies of states τ apart, on a grid of lags in seconds."""

    taus: FloatArray  # seconds
    matrices: FloatArray  # (len(taus), STATES, STATES)


def lag_grid(span: float, step: float) -> FloatArray:
    """Lags from ``step`` up to :data:`MAX_LAG_SHARE` of ``span``, growing geometrically."""
    out = [step]
    while out[-1] * LAG_GROWTH < MAX_LAG_SHARE * span:
        out.append(max(out[-1] * LAG_GROWTH, out[-1] + step))
    return np.asarray(out, dtype=np.float64)


def lags(st: npt.NDArray[np.int8], times: FloatArray, taus: FloatArray) -> list[Lags]:
    """Per row of ``st``, its joint state frequencies at the lags ``taus``."""
    n = st.shape[1]
    dt = float(np.median(np.diff(times))) if times.size > 1 else 1.0
    dt = dt if dt > 0 else 1.0
    steps = np.maximum(1, np.round(taus / dt)).astype(np.int64)
    out = []
    for row in st.astype(np.int64):
        mats = np.zeros((taus.size, STATES, STATES))
        for j, k in enumerate(steps.tolist()):
            if k >= n:
                break
            pairs = np.bincount(row[:-k] * STATES + row[k:], minlength=STATES * STATES)
            mats[j] = pairs.reshape(STATES, STATES) / max(n - k, 1)
        out.append(Lags(taus, mats))
    return out


def null_variance(
    pa: FloatArray, pb: FloatArray, c: float, la: Lags, lb: Lags, checks: int, dt: float
) -> float:
    """The variance of Σ(match − c·counted) over ``checks`` checks dt apart when the two
    signals are independent (the module's formula)."""
    u = MATCHED.astype(np.float64) - c * COUNTED.astype(np.float64)
    gamma0 = float(pa @ (u * u) @ pb)
    total = 0.0
    edges = np.concatenate([[dt / 2], np.sqrt(la.taus[:-1] * la.taus[1:]), [la.taus[-1] * 1.15]])
    for j in range(la.taus.size):
        gamma = float(np.sum(u * (la.matrices[j] @ u @ lb.matrices[j].T)))
        if not gamma > 0:
            break
        lags_here = max(0.0, math.floor(edges[j + 1] / dt) - math.floor(edges[j] / dt))
        total += gamma * lags_here
    return max(checks * (gamma0 + 2 * total), 0.0)


@dataclass(frozen=True, slots=True)
class PairEvidence:
    """One pair's agreement on one stretch of recording (its trends computed from it)."""

    matches: int
    checks: int  # counted checks: at least one side moving
    chance: float
    variance: float  # of Σ(match − chance·counted) under independence

    @property
    def ratio(self) -> float:
        return self.matches / self.checks if self.checks else 0.0

    @property
    def lift(self) -> float:
        return self.ratio - self.chance if self.checks else 0.0

    @property
    def effective(self) -> float:
        """The effective number of independent checks (none when chance alone explains
        every check: two signals that always show one trend carry no evidence)."""
        if self.variance <= 0 or self.checks == 0:
            return 0.0
        return self.chance * (1 - self.chance) * self.checks**2 / self.variance


@dataclass(frozen=True, slots=True)
class Pooled:
    """Evidence pooled over several stretches (independent: their variances add)."""

    ratio: float
    chance: float
    z: float
    p: float
    checks: int
    effective: float


def pooled(parts: Sequence[PairEvidence]) -> Pooled:
    checks = sum(e.checks for e in parts)
    if checks == 0:
        return Pooled(0.0, 0.0, 0.0, 1.0, 0, 0.0)
    matches = sum(e.matches for e in parts)
    expected = sum(e.chance * e.checks for e in parts)
    variance = sum(e.variance for e in parts)
    ratio, c = matches / checks, expected / checks
    if not variance > 0:  # chance explains every check: no evidence either way
        return Pooled(ratio, c, 0.0, 0.5, checks, 0.0)
    z = (matches - expected) / math.sqrt(variance)
    effective = c * (1 - c) * checks**2 / variance
    return Pooled(ratio, c, z, 0.5 * math.erfc(z / math.sqrt(2)), checks, effective)


class TrendSet:
    """The trends of one stretch of recording, with what the evidence of any pair needs:
    each topic's states, state frequencies and lag matrices, computed once."""

    def __init__(self, trends: Mapping[str, TopicTrends]) -> None:
        self.trends = dict(trends)
        self._states = {n: states(t) for n, t in self.trends.items()}
        self._freqs = {n: frequencies(s) for n, s in self._states.items()}
        spans = [float(t.times[-1] - t.times[0]) for t in self.trends.values() if t.times.size]
        steps = [
            float(np.median(np.diff(t.times))) for t in self.trends.values() if t.times.size > 1
        ]
        step = min([s for s in steps if s > 0], default=0.02)
        self._taus = lag_grid(max(spans, default=1.0), step)
        self._lags: dict[str, list[Lags]] = {}

    def _lag(self, topic: str) -> list[Lags]:
        if topic not in self._lags:
            t = self.trends[topic]
            self._lags[topic] = lags(self._states[topic], t.times, self._taus)
        return self._lags[topic]

    def evidence(self, pairs: Sequence[tuple[Signal, Signal]]) -> list[PairEvidence | None]:
        """Per pair, its evidence here (None: a side has no trend in this stretch)."""
        out: list[PairEvidence | None] = [None] * len(pairs)
        groups: dict[tuple[str, str], list[int]] = {}
        for i, (a, b) in enumerate(pairs):
            ta, tb = self.trends.get(a.topic), self.trends.get(b.topic)
            if ta is None or tb is None or ta.row(a) is None or tb.row(b) is None:
                continue
            groups.setdefault((a.topic, b.topic), []).append(i)
        for (x, y), members in groups.items():
            rows_x = [self.trends[x].signals.index(pairs[i][0]) for i in members]
            rows_y = [self.trends[y].signals.index(pairs[i][1]) for i in members]
            found = self._topic_pair(x, y, rows_x, rows_y)
            for i, e in zip(members, found, strict=True):
                out[i] = e
        return out

    def quadrants(
        self, pairs: Sequence[tuple[Signal, Signal]], headings: Sequence[Heading]
    ) -> list[Quadrants | None]:
        """Per pair, its checks by the quadrant of every heading (both directions pooled);
        the other side's states and each heading's quadrants are computed once per topic."""
        out: list[Quadrants | None] = [None] * len(pairs)
        if not headings:
            return out
        names = tuple(h[0] for h in headings)
        at: dict[tuple[str, str], tuple[npt.NDArray[np.int8], FloatArray]] = {}
        quads: dict[str, list[npt.NDArray[np.int64]]] = {}
        for i, (a, b) in enumerate(pairs):
            x, y = self.trends.get(a.topic), self.trends.get(b.topic)
            if x is None or y is None or x.row(a) is None or y.row(b) is None:
                continue
            shape = (len(headings), 4)
            inside, counted, matched = np.zeros(shape), np.zeros(shape), np.zeros(shape)
            own_f, other_f = np.zeros((*shape, STATES)), np.zeros((*shape, STATES))
            sides = ((x, y, x.row(a), y.row(b)), (y, x, y.row(b), x.row(a)))
            for own, other, r_own, r_other in sides[: 1 if x.topic == y.topic else 2]:
                assert r_own is not None and r_other is not None
                key = (own.topic, other.topic)
                if key not in at:
                    at[key] = states_at(own.times, other)
                if own.topic not in quads:
                    quads[own.topic] = [quadrant(own.times, h) for h in headings]
                theirs, ok = at[key]
                keep = ok > 0
                s_own = self._states[own.topic][r_own][keep].astype(np.intp)
                s_other = theirs[r_other][keep].astype(np.intp)
                flat = s_own * STATES + s_other
                for h in range(len(headings)):
                    q = quads[own.topic][h][keep]
                    inside[h] += np.bincount(q, minlength=4)
                    counted[h] += np.bincount(q, weights=COUNTED.reshape(-1)[flat], minlength=4)
                    matched[h] += np.bincount(q, weights=MATCHED.reshape(-1)[flat], minlength=4)
                    own_f[h] += np.bincount(q * STATES + s_own, minlength=4 * STATES).reshape(
                        4, STATES
                    )
                    other_f[h] += np.bincount(q * STATES + s_other, minlength=4 * STATES).reshape(
                        4, STATES
                    )
            out[i] = Quadrants(names, inside, counted, matched, own_f, other_f)
        return out

    def _direction(
        self, own: str, other: str, rows_own: list[int], rows_other: list[int]
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], int, float]:
        """Matches and counted checks of ``own``'s samples against ``other`` at their
        times, per pair; how many times lie inside ``other``'s span; own's spacing."""
        mine = self.trends[own]
        theirs, inside = states_at(mine.times, self.trends[other])
        a = self._states[own][rows_own].astype(np.intp)
        b = theirs[rows_other].astype(np.intp)
        ok = b >= 0
        flat = np.where(ok, a * STATES + np.maximum(b, 0), 0)
        matched = (MATCHED.reshape(-1)[flat] & ok).sum(axis=1)
        counted = (COUNTED.reshape(-1)[flat] & ok).sum(axis=1)
        span = float(mine.times[-1] - mine.times[0]) if mine.times.size > 1 else 0.0
        n_inside = int(inside.sum())
        dt = span / max(mine.times.size - 1, 1) if span > 0 else 1.0
        return matched.astype(np.int64), counted.astype(np.int64), n_inside, dt

    def _topic_pair(
        self, x: str, y: str, rows_x: list[int], rows_y: list[int]
    ) -> list[PairEvidence | None]:
        if x == y:
            m1, c1, n1, dt1 = self._direction(x, x, rows_x, rows_y)
            directions = [(m1, c1, n1, dt1, rows_x, rows_y, x, y)]
            scale = 2
        else:
            m1, c1, n1, dt1 = self._direction(x, y, rows_x, rows_y)
            m2, c2, n2, dt2 = self._direction(y, x, rows_y, rows_x)
            directions = [
                (m1, c1, n1, dt1, rows_x, rows_y, x, y),
                (m2, c2, n2, dt2, rows_y, rows_x, y, x),
            ]
            scale = 1
        out: list[PairEvidence | None] = []
        for k in range(len(rows_x)):
            pa, pb = self._freqs[x][rows_x[k]], self._freqs[y][rows_y[k]]
            c = chance(pa, pb)
            matches = scale * sum(int(d[0][k]) for d in directions)
            checks = scale * sum(int(d[1][k]) for d in directions)
            if checks == 0:
                out.append(PairEvidence(0, 0, c, 0.0))
                continue
            spread = 0.0
            for _, _, n, dt, ro, rt, own, other in directions:
                p_own, p_other = self._freqs[own][ro[k]], self._freqs[other][rt[k]]
                v = null_variance(
                    p_own, p_other, c, self._lag(own)[ro[k]], self._lag(other)[rt[k]], n, dt
                )
                spread += math.sqrt(v)
            out.append(PairEvidence(matches, checks, c, (scale * spread) ** 2))
        return out


Heading = tuple[str, FloatArray, FloatArray]  # a yaw signal: its name, times, values


@dataclass(frozen=True, slots=True, eq=False)
class Quadrants:
    """One pair's checks split by the quadrant of each heading signal ([0°, 90°), …): how
    many lie there, how many of them count, match, and each side's states among them."""

    names: tuple[str, ...]
    inside: FloatArray  # (headings, 4)
    counted: FloatArray
    matched: FloatArray
    own: FloatArray  # (headings, 4, STATES)
    other: FloatArray

    def __add__(self, more: Quadrants) -> Quadrants:
        if self.names != more.names:
            return self if self.inside.sum() >= more.inside.sum() else more
        return Quadrants(
            self.names,
            self.inside + more.inside,
            self.counted + more.counted,
            self.matched + more.matched,
            self.own + more.own,
            self.other + more.other,
        )

    def worst(self, min_checks: float, min_share: float) -> tuple[float, str, int] | None:
        """The lowest lift (ratio − chance) in a quadrant holding enough checks, with the
        heading and the quadrant; None when no quadrant holds enough."""
        worst: tuple[float, str, int] | None = None
        total = self.inside.sum(axis=1)
        for h, name in enumerate(self.names):
            for q in range(4):
                n, counted = self.inside[h, q], self.counted[h, q]
                if n < max(min_checks, min_share * total[h]) or counted <= 0:
                    continue
                c = chance(self.own[h, q] / n, self.other[h, q] / n)
                lift = self.matched[h, q] / counted - c
                if worst is None or lift < worst[0]:
                    worst = (lift, name, q)
        return worst


def quadrant(times: FloatArray, heading: Heading) -> npt.NDArray[np.int64]:
    """The quadrant of ``heading`` at ``times`` (0: [0°, 90°), …)."""
    yaw = np.interp(times, heading[1], heading[2])
    out: npt.NDArray[np.int64] = (
        np.floor(np.mod(yaw, 2 * np.pi) / (np.pi / 2)).astype(np.int64).clip(0, 3)
    )
    return out


def quadrants(
    trends: Mapping[str, TopicTrends], pair: tuple[Signal, Signal], headings: Sequence[Heading]
) -> Quadrants | None:
    """One pair's checks by the quadrant of every heading (both directions pooled)."""
    return TrendSet(trends).quadrants([pair], headings)[0]


def _one_row(t: TopicTrends, row: int) -> TopicTrends:
    return TopicTrends(
        t.topic,
        t.times,
        (t.signals[row],),
        t.codes[row : row + 1],
        t.rest[row : row + 1],
        t.window_s,
        t.bands[row : row + 1],
        t.floors[row : row + 1],
    )
