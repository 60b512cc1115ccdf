"""QObs (Algorithm 4, errata) and BiQObs (Algorithm 5).

The hand-computed traces use a sample a second and ω = 2 s, so an inner window holds three
samples c−1, c, c+1 and its least-squares slope is (v(c+1) − v(c−1))/2; the first window
[−1, 1] holds two samples, slope v(1) − v(0).  A regression's slope for c is known when a
sample beyond c + 1 comes, so the trend of sample c (three regressions) is decided by sample
c + 6.  The statistical tests use seeded noisy traces at 10 and 100 Hz with ω = 1 s.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from rac.logic import Atom
from rac.observe import Message, Verdict, build
from rac.observe import qobs as qobs_module
from rac.observe.biqobs import BiQObs
from rac.observe.qobs import MIN_HISTORY, QObs, SlidingSlope, Trend, TrendAt
from rac.passes.observers import ObserverSpec, ParamValue

D, C, INC = Trend.DEC, Trend.CONS, Trend.INC


def trends(q: QObs, values: list[float]) -> list[tuple[float, Trend]]:
    out = []
    for t, v in enumerate(values):
        out += q.push(float(t), v)
    return out


def run(q: QObs, times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (sample time, trend code) pairs the observer decides over a trace."""
    out = []
    for t, v in zip(times.tolist(), values.tolist(), strict=True):
        out += q.push(t, v)
    return np.array([c for c, _ in out]), np.array([int(tr) for _, tr in out])


def test_sliding_slope_and_its_standard_error_match_least_squares() -> None:
    rng = np.random.default_rng(7)
    times = np.cumsum(rng.uniform(0.05, 0.15, 60))
    values = 0.3 * times + np.sin(times) + rng.normal(0, 0.05, times.size)
    s = SlidingSlope(0.4)
    out = []
    for t, v in zip(times.tolist(), values.tolist(), strict=True):
        out += s.push(t, v)
    assert len(out) > 50
    for centre, slope, se in out:
        inside = np.abs(times - centre) <= 0.4 + 1e-12
        t, v = times[inside], values[inside]
        beta, alpha = np.polyfit(t, v, 1)
        residuals = v - (alpha + beta * t)
        sxx = np.sum((t - t.mean()) ** 2)
        expected_se = math.sqrt(np.sum(residuals**2) / (t.size - 2) / sxx)
        assert slope == pytest.approx(beta, rel=1e-9, abs=1e-12)
        assert se == pytest.approx(expected_se, rel=1e-6)


def test_sliding_slope_on_two_samples_and_exact_lines() -> None:
    s = SlidingSlope(1.0)
    out = []
    for t, v in enumerate([0.0, 1.0, 4.0, 9.0, 16.0]):
        out += s.push(float(t), v)
    # c=0: two samples, (1−0)/1 = 1 and no SE; c=1: (4−0)/2 = 2 over 0, 1, 4, residuals
    # (0, 1, 4) − (−1/3 + 2t) = 1/3, −2/3, 1/3, SSR = 2/3, Sxx = 2: SE = √(2/3 / 1 / 2) = 1/√3.
    assert [(c, slope) for c, slope, _ in out] == [(0.0, 1.0), (1.0, 2.0), (2.0, 4.0)]
    assert out[0][2] == 0.0
    assert out[1][2] == pytest.approx(1 / math.sqrt(3))
    line = SlidingSlope(1.0)
    exact = []
    for t in range(8):
        exact += line.push(float(t), 3.0 - 0.5 * t)
    assert all(slope == pytest.approx(-0.5) and se < 1e-9 for _, slope, se in exact)


def test_slopes_stay_exact_on_a_late_clock_and_a_large_integral() -> None:
    # Epoch-sized times and values past 1e6: the moving origin keeps the slope of v = 2t at
    # 2 to many digits.
    s = SlidingSlope(0.5)
    base = 1.7e9
    out = []
    for k in range(5000):
        t = base + 0.01 * k
        out += s.push(t, 1e6 + 2.0 * (t - base))
    assert len(out) > 4000
    assert max(abs(slope - 2.0) for _, slope, _ in out[10:]) < 1e-6


# Algorithm 4 with β_p = slope, β_n = −slope given by the spec.


def test_increasing_decreasing_constant() -> None:
    # v = t: every slope 1 > β_p = 0.5, second and third derivatives 0.  Ten samples decide
    # the trends of samples 0..3, each at sample c + 6; a given slope needs no history.
    assert trends(QObs(2.0, slope=0.5), [float(t) for t in range(10)]) == [
        (0.0, INC),
        (1.0, INC),
        (2.0, INC),
        (3.0, INC),
    ]
    assert [tr for _, tr in trends(QObs(2.0, slope=0.5), [-float(t) for t in range(10)])] == [D] * 4
    assert [tr for _, tr in trends(QObs(2.0, slope=0.5), [3.0] * 10)] == [C] * 4
    q = QObs(2.0, slope=0.5)
    trends(q, [float(t) for t in range(10)])
    assert q.limits() == (-0.5, 0.5)


def test_undecided_sample_holds_the_previous_trend() -> None:
    # A spike at t = 4: v = 0 0 0 0 1 0 0 0 ...; β_p = 0.4, β_n = −0.4.
    # s1: c3 = (1−0)/2 = .5, c4 = 0, c5 = (0−1)/2 = −.5, all others 0.
    # s2: c2 = (s1(3) − s1(1))/2 = .25, c3 = 0, c4 = (−.5 − .5)/2 = −.5, c5 = 0, c6 = .25,
    #     c0 = s1(1) − s1(0) = 0, c1 = (s1(2) − s1(0))/2 = 0, c7 = 0.
    # s3: c1 = (s2(2) − s2(0))/2 = .125, c2 = 0, c3 = (−.5 − .25)/2 = −.375, c4 = 0,
    #     c5 = (.25 + .5)/2 = .375, c6 = 0, c7 = (s2(8) − s2(6))/2 = −.125, c0 = 0.
    # c0-c2: s1 = 0 and s2, s3 within (−.4, .4): cons.  c3: s1 = .5 > .4: inc.
    # c4: s1 = 0 but s2 = −.5 is outside: the previous trend holds, inc.  c5: s1 = −.5: dec.
    # c6, c7: cons.
    values = [0.0, 0.0, 0.0, 0.0, 1.0] + [0.0] * 9
    assert trends(QObs(2.0, slope=0.4), values) == [
        (0.0, C),
        (1.0, C),
        (2.0, C),
        (3.0, INC),
        (4.0, INC),
        (5.0, D),
        (6.0, C),
        (7.0, C),
    ]


def test_integrated_side_uses_the_running_sum() -> None:
    # A constant field of 1 is flat, but its running sum 1, 2, 3, ... rises with slope 1.
    assert [tr for _, tr in trends(QObs(2.0, slope=0.5), [1.0] * 10)] == [C] * 4
    assert [tr for _, tr in trends(QObs(2.0, integral=True, slope=0.5), [1.0] * 10)] == [INC] * 4
    assert [tr for _, tr in trends(QObs(2.0, integral=True, slope=0.5), [-1.0] * 10)] == [D] * 4


def test_a_given_slope_replaces_the_significance_test() -> None:
    # A ramp of 0.3/s under noise: far above its noise (3·SE ≈ 0.1), so it is inc without a
    # given slope; β_p = 1 calls it constant, β_p = 0.2 increasing.
    rng = np.random.default_rng(11)
    times = np.arange(0.0, 30.0, 0.01)
    values = 0.3 * times + rng.normal(0, 0.1, times.size)
    for slope, expected in ((None, INC), (1.0, C), (0.2, INC)):
        _, got = run(QObs(1.0, slope=slope), times, values)
        assert set(got.tolist()) == {int(expected)}, slope


# The online limits: β_p = max(SIGNIFICANCE·SE, floor), β_n = −β_p.


def test_no_trend_before_the_history_fills() -> None:
    # One |β| joins the history per half window, here every sample (ω/2 = 1 s): the slope of
    # sample k is the (k+1)-th, known at sample k + 2.  The MIN_HISTORY-th comes with sample
    # MIN_HISTORY + 1, which also decides the trend of sample MIN_HISTORY + 1 − 6.
    q = QObs(2.0)
    values = [math.sin(t / 3) for t in range(MIN_HISTORY + 10)]
    decided_at = []
    for t, v in enumerate(values):
        decided_at += [(t, c) for c, _ in q.push(float(t), v)]
    assert decided_at[0] == (MIN_HISTORY + 1, float(MIN_HISTORY - 5))
    assert [c for _, c in decided_at] == [float(c) for c in range(MIN_HISTORY - 5, len(values) - 6)]
    low, high = q.limits() or (0.0, 0.0)
    assert low == -high and high > 0
    # At 100 Hz with ω = 1 s the history takes one |β| every 0.5 s: MIN_HISTORY of them
    # take MIN_HISTORY·ω/2 (10 s), then the last slope needs ω/2 more samples.
    fast = QObs(1.0)
    first = None
    for k in range(2000):
        if fast.push(k / 100, math.sin(k / 100)) and first is None:
            first = k / 100
    assert first is not None
    assert MIN_HISTORY * 0.5 <= first <= MIN_HISTORY * 0.5 + 0.2


def test_a_ramp_well_above_the_noise_is_a_trend() -> None:
    rng = np.random.default_rng(1)
    times = np.arange(0.0, 40.0, 0.01)
    noise = rng.normal(0, 0.1, times.size)
    for sign, expected in ((1.0, INC), (-1.0, D)):
        centres, got = run(QObs(1.0), times, sign * 0.5 * times + noise)
        assert centres.size > 2500
        assert set(got.tolist()) == {int(expected)}


def test_a_noisy_flat_signal_is_constant() -> None:
    # Level-1 false positives are rare (|β| > 3·SE on about 0.05 % of samples); the
    # derivatives are held to the slope's own limit (Algorithm 4), so an undecided sample is
    # rare too and a false inc/dec is not held for long (measured: 97.8 % constant).
    rng = np.random.default_rng(4)
    times = np.arange(0.0, 60.0, 0.01)
    _, got = run(QObs(1.0), times, rng.normal(0, 0.1, times.size))
    assert np.mean(got == int(C)) > 0.97


def test_the_floor_keeps_random_walk_drift_constant(monkeypatch: pytest.MonkeyPatch) -> None:
    # An integrated yaw rate at 100 Hz: zero-mean noise (σ = 0.05) with a turn at rate 1
    # from 2 s to 4 s of every 20 s.  The running sum rises at 100/s in a turn; at rest it
    # is a random walk whose slope (~0.5/s) is significant against its own residuals but
    # below the floor, 5 % of the 95th percentile of |β| (about 5/s).
    rng = np.random.default_rng(1)
    times = np.arange(0.0, 60.0, 0.01)
    rate = rng.normal(0, 0.05, times.size) + np.where(times % 20 < 4, 1.0, 0.0) * (times % 20 >= 2)

    def phase(c: np.ndarray) -> np.ndarray:
        return c % 20

    centres, got = run(QObs(1.0, integral=True), times, rate)
    at_rest = (phase(centres) >= 6) & (phase(centres) < 19)
    turning = (phase(centres) >= 2.8) & (phase(centres) < 3.2)
    assert at_rest.sum() > 2500 and turning.sum() > 50
    assert set(got[at_rest].tolist()) == {int(C)}
    assert set(got[turning].tolist()) == {int(INC)}
    # Without the floor and the noise band the significance test alone keeps the drift
    # constant too: an integrated side's slope error comes from the scatter of the samples
    # it sums, not from the residuals of the random walk (which read it as trends).
    monkeypatch.setattr(qobs_module, "FLOOR_FRACTION", 0.0)
    monkeypatch.setattr(qobs_module, "noise_band", lambda history, fast: 0.0)
    centres, got = run(QObs(1.0, integral=True), times, rate)
    at_rest = (phase(centres) >= 6) & (phase(centres) < 19)
    assert np.mean(got[at_rest] == int(C)) > 0.9
    monkeypatch.setattr(qobs_module, "SlidingMean", _NoScatter)
    centres, got = run(QObs(1.0, integral=True), times, rate)
    at_rest = (phase(centres) >= 6) & (phase(centres) < 19)
    assert np.mean(got[at_rest] == int(C)) < 0.5


class _NoScatter(qobs_module.SlidingMean):
    """A SlidingMean that contributes nothing: the regression's own residuals alone."""

    __slots__ = ()

    def _slope(self) -> tuple[float, float]:
        return 0.0, 0.0


def test_admits_within_a_factor_of_the_limit() -> None:
    # β_p = 1: a slope lies clearly on one side of a limit when beyond a factor MARGIN = 2.
    assert TrendAt(0.0, INC, 1.5, 1.0).admits(INC)
    assert TrendAt(0.0, INC, 1.5, 1.0).admits(C)  # 1.5 <= 2·β_p
    assert not TrendAt(0.0, INC, 2.5, 1.0).admits(C)
    assert not TrendAt(0.0, INC, 1.5, 1.0).admits(D)
    assert TrendAt(0.0, C, 0.6, 1.0).admits(INC)  # 0.6 > β_p/2
    assert not TrendAt(0.0, C, 0.4, 1.0).admits(INC)
    assert TrendAt(0.0, C, -0.6, 1.0).admits(D)
    assert not TrendAt(0.0, C, -0.6, 1.0).admits(INC)
    assert TrendAt(0.0, D, -1.9, 1.0).admits(C)
    assert not TrendAt(0.0, D, -1.9, 1.0).admits(INC)


def test_recent_trends_and_at() -> None:
    q = QObs(2.0, slope=0.5)
    trends(q, [float(t) for t in range(20)])  # trends of samples 0..13
    assert [s.t for s in q.recent] == [9.0, 10.0, 11.0, 12.0, 13.0]  # the last 2ω
    assert q.at(8.5) is None
    found = q.at(11.5)
    assert found == TrendAt(11.0, INC, 1.0, 0.5)
    assert q.at(100.0) == TrendAt(13.0, INC, 1.0, 0.5)


MATCHED = Atom("matched", ("a", "x", "b", "y"))


def biq(**params: ParamValue) -> ObserverSpec:
    base: dict[str, ParamValue] = {
        "topic1": "/a",
        "field1": "x",
        "topic2": "/b",
        "field2": "y",
        "mismatch_th": 1,
        "ws": 2.0,
        "slope1": 0.5,
        "slope2": 0.5,
    }
    base.update(params)
    return ObserverSpec("BiQObs", "biq1_biqobs", tuple(base.items()), (MATCHED,))


def online(**params: ParamValue) -> ObserverSpec:
    """A BiQObs as the compiler makes it: ω = 1 s, θ = 5, online limits."""
    base: dict[str, ParamValue] = {"topic1": "/a", "field1": "x", "topic2": "/b", "field2": "y"}
    base.update(params)
    return ObserverSpec("BiQObs", "biq1_biqobs", tuple(base.items()), (MATCHED,))


def feed_pair(spec: ObserverSpec, f1: list[float], f2: list[float]) -> list[Verdict]:
    obs = build(spec)
    out = []
    for t, (a, b) in enumerate(zip(f1, f2, strict=True)):
        out += obs.feed(Message(float(t), "/a", {"x": a}))
        out += obs.feed(Message(float(t), "/b", {"y": b}))
    return out


def feed_streams(
    spec: ObserverSpec, a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]
) -> list[tuple[float, str]]:
    """Feed two (times, values) streams merged in time order; the verdicts as text."""
    events = [(t, "/a", "x", v) for t, v in zip(a[0].tolist(), a[1].tolist(), strict=True)]
    events += [(t, "/b", "y", v) for t, v in zip(b[0].tolist(), b[1].tolist(), strict=True)]
    events.sort(key=lambda e: e[0])
    obs = build(spec)
    out = []
    for t, topic, field, v in events:
        out += obs.feed(Message(t, topic, {field: v}))
    return trace(out)


def trace(verdicts: list[Verdict]) -> list[tuple[float, str]]:
    return [(v.t, str(v)) for v in verdicts]


def test_biqobs_matched() -> None:
    # Checks every ω/2 = 1 s from the first event (t = 0): instants 1, 2, ...  Both sides'
    # first trends (of sample 0) come with the samples at t = 6, so the first check is at 7.
    out = feed_pair(biq(), [float(t) for t in range(20)], [2.0 * t for t in range(20)])
    assert trace(out) == [(7.0, "matched(a,x,b,y)")]


def test_biqobs_mismatched_after_theta() -> None:
    # inc against dec: t7 count 1 <= θ = 1 (the first verdict is positive), t8 count 2.
    out = feed_pair(biq(), [float(t) for t in range(20)], [-float(t) for t in range(20)])
    assert trace(out) == [(7.0, "matched(a,x,b,y)"), (8.0, "not_matched(a,x,b,y)")]


def test_biqobs_integrated_side_and_advance() -> None:
    # Side 2 is I(y) with y = 1: its running sum rises like side 1.
    obs = build(biq(integral2=True))
    out = []
    for t in range(8):
        out += obs.feed(Message(float(t), "/a", {"x": float(t)}))
        out += obs.feed(Message(float(t), "/b", {"y": 1.0}))
    assert trace(out) == [(7.0, "matched(a,x,b,y)")]
    # With no more input, advance keeps checking the latest trends: nothing changes.
    assert obs.advance(1000.0) == []


def test_biqobs_one_topic_and_no_verdict_without_both_trends() -> None:
    spec = biq(topic2="/a")
    obs = build(spec)
    out = []
    for t in range(20):  # field y never comes: side 2 has no trend
        out += obs.feed(Message(float(t), "/a", {"x": float(t)}))
    assert out == []
    both = build(spec)
    for t in range(8):
        out += both.feed(Message(float(t), "/a", {"x": float(t), "y": -float(t)}))
    assert trace(out) == [(7.0, "matched(a,x,b,y)")]  # count 1 <= θ


@pytest.mark.parametrize("ws", [None, 0.5])
def test_biqobs_window_default(ws: float | None) -> None:
    params = {} if ws is None else {"ws": ws}
    spec = ObserverSpec(
        "BiQObs",
        "b",
        (("topic1", "/a"), ("field1", "x"), ("topic2", "/b"), ("field2", "y"), *params.items()),
        (MATCHED,),
    )
    obs = build(spec)
    assert getattr(obs, "ws") == (1.0 if ws is None else ws)  # noqa: B009


RATES = (0.0, 0.5, 0.0, -0.3, 0.0, 1.0, -1.0, 0.0, 0.1, 0.0, -0.6, 0.2)  # rad/s, 8 s each


def heading(t: np.ndarray) -> np.ndarray:
    """A robot's heading: turns at the rates of RATES, 8 s each, over and over."""
    rates = np.array(RATES)
    at_start = np.concatenate([[0.0], np.cumsum(rates * 8.0)])
    phase = np.floor(t / 8.0).astype(int)
    k = phase % rates.size
    turned: np.ndarray = (
        np.floor(phase / rates.size) * at_start[-1] + at_start[k] + rates[k] * (t - 8.0 * phase)
    )
    return turned


def test_biqobs_two_noisy_copies_at_different_rates_match() -> None:
    # The same heading seen at 10 Hz and at 100 Hz with independent noise, for 3 minutes:
    # turns fast and slow (0.1 rad/s), standing still, reversing.
    rng = np.random.default_rng(0)
    slow, fast = np.arange(0.0, 180.0, 0.1), np.arange(0.0, 180.0, 0.01)
    out = feed_streams(
        online(),
        (slow, heading(slow) + rng.normal(0, 0.02, slow.size)),
        (fast, heading(fast) + rng.normal(0, 0.02, fast.size)),
    )
    assert out == [(10.5, "matched(a,x,b,y)")]


@functools.cache
def divergence(seed: int) -> tuple[tuple[float, str], ...]:
    """Two noisy flat signals (σ = 0.05, 100 Hz); from 30 s side 1 rises at 0.5/s."""
    rng = np.random.default_rng(seed)
    times = np.arange(0.0, 45.0, 0.01)
    a = np.where(times > 30.0, 0.5 * (times - 30.0), 0.0) + rng.normal(0, 0.05, times.size)
    b = rng.normal(0, 0.05, times.size)
    return tuple(feed_streams(online(), (times, a), (times, b)))


SEEDS = range(6)


def test_biqobs_a_divergence_is_not_matched() -> None:
    for seed in SEEDS:
        out = divergence(seed)
        # Both sides rest until 30 s: the relation says nothing, or, where noise moved a
        # side past its limit for a moment, matched; never not matched.
        assert all(str_ == "matched(a,x,b,y)" for t, str_ in out if t <= 30.0), seed
        first = min(t for t, str_ in out if str_.startswith("not_"))
        assert first <= 40.0, seed
        assert out[-1][1] == "not_matched(a,x,b,y)", seed


def test_biqobs_a_divergence_is_not_matched_within_eight_seconds_for_good() -> None:
    # The rise shows in a trend about 3ω/2 after it starts and must then outlast θ checks
    # (one per ω/2); the slowest seed reads not matched at 37 s.
    for seed in SEEDS:
        out = divergence(seed)
        failed = [(t, str_) for t, str_ in out if str_.startswith("not_")]
        assert failed and failed[0][0] <= 38.0, (seed, out)
        assert out[-1] == failed[0], (seed, out)  # and for good


def test_biqobs_two_independent_flat_signals_say_nothing() -> None:
    # Two noise signals both rest: no stale opposite trends are held between them, and a
    # relation between two resting sides gives no verdict (a robot standing still neither
    # confirms nor breaks it).
    rng = np.random.default_rng(7)
    times = np.arange(0.0, 60.0, 0.01)
    a, b = rng.normal(0, 0.05, times.size), rng.normal(0, 0.05, times.size)
    assert feed_streams(online(), (times, a), (times, b)) == []


def test_biqobs_compares_the_two_sides_at_the_same_time() -> None:
    # A triangle wave (up 10 s, down 10 s) at 100 Hz and at 1 Hz, ω = 2 s, β_p = 0.5.  The
    # trend of sample c is known about c + 3 s on the fast side and c + 6 s on the slow one,
    # so after each reversal the latest trends disagree (inc against dec) at more than θ = 3
    # consecutive checks (one a second); compared at the same time they agree.
    def tri(t: np.ndarray) -> np.ndarray:
        return np.where(t % 20 < 10, t % 20, 20 - t % 20)

    fast, slow = np.arange(0.0, 60.0, 0.01), np.arange(0.0, 60.0, 1.0)
    spec = biq(ws=2.0, mismatch_th=3)
    assert feed_streams(spec, (fast, tri(fast)), (slow, tri(slow))) == [(7.0, "matched(a,x,b,y)")]
    obs = build(spec)
    events = [(t, "/a", "x", v) for t, v in zip(fast.tolist(), tri(fast).tolist(), strict=True)]
    events += [(t, "/b", "y", v) for t, v in zip(slow.tolist(), tri(slow).tolist(), strict=True)]
    events.sort(key=lambda e: e[0])
    run_, longest = 0, 0
    for t, topic, field, v in events:
        obs.feed(Message(t, topic, {field: v}))
        latest = {getattr(obs, "side1").latest, getattr(obs, "side2").latest}  # noqa: B009
        if topic == "/a" and abs(t - round(t)) < 1e-9:  # the check grid, every ω/2
            run_ = run_ + 1 if latest == {INC, D} else 0
            longest = max(longest, run_)
    assert longest > 3


def test_biqobs_counts_no_mismatch_while_starved_and_three_windows_after() -> None:
    obs = build(biq())
    assert isinstance(obs, BiQObs)
    out = []
    for t in range(20):
        if t == 5:
            obs.starved(5.0, True)
        if t == 12:
            obs.starved(12.0, False)  # mismatches count again from 12 + 3ω = 18
        out += obs.feed(Message(float(t), "/a", {"x": float(t)}))
        out += obs.feed(Message(float(t), "/b", {"y": -float(t)}))
    # The first check (7) falls in the starvation: nothing counts until 18 (count 1, the
    # first verdict is positive), 19 gives count 2 > θ.
    assert trace(out) == [(18.0, "matched(a,x,b,y)"), (19.0, "not_matched(a,x,b,y)")]
