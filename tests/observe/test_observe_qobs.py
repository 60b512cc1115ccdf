"""QObs (Algorithm 4, errata) and BiQObs (Algorithm 5) on hand-computed traces.

Samples come once a second and ω = 2 s, so an inner window holds three samples c−1, c, c+1
and its least-squares slope is (v(c+1) − v(c−1))/2; the first window [−1, 1] holds two
samples, slope v(1) − v(0).  A regression's slope for c is known when a sample beyond c + 1
comes, so the trend of sample c (three regressions) is decided by sample c + 6.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rac.learn.trends import classify, window_bounds, windowed_slopes
from rac.logic import Atom
from rac.observe import Message, Verdict, build
from rac.observe.qobs import MIN_SLOPES, QObs, SlidingSlope, Trend
from rac.passes.observers import ObserverSpec, ParamValue

D, C, INC = Trend.DEC, Trend.CONS, Trend.INC


def trends(q: QObs, values: list[float]) -> list[tuple[float, Trend]]:
    out = []
    for t, v in enumerate(values):
        out += q.push(float(t), v)
    return out


def test_sliding_slope_matches_the_formula() -> None:
    s = SlidingSlope(1.0)
    values = [0.0, 1.0, 4.0, 9.0, 16.0]
    out = []
    for t, v in enumerate(values):
        out += s.push(float(t), v)
    # c=0: (1−0)/1 = 1; c=1: (4−0)/2 = 2; c=2: (9−1)/2 = 4 (c=3, 4 wait for later samples).
    assert out == [(0.0, 1.0), (1.0, 2.0), (2.0, 4.0)]


def test_increasing_decreasing_constant() -> None:
    # v = t: every slope 1 > β_p = 0.5, second and third derivatives 0.  Ten samples decide
    # the trends of samples 0..3, each at sample c + 6.
    assert trends(QObs(2.0, slope=0.5), [float(t) for t in range(10)]) == [
        (0.0, INC),
        (1.0, INC),
        (2.0, INC),
        (3.0, INC),
    ]
    assert [tr for _, tr in trends(QObs(2.0, slope=0.5), [-float(t) for t in range(10)])] == [D] * 4
    assert [tr for _, tr in trends(QObs(2.0, slope=0.5), [3.0] * 10)] == [C] * 4


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


def test_online_limits_wait_for_enough_slopes() -> None:
    q = QObs(2.0)
    values = [math.sin(t / 3) for t in range(MIN_SLOPES + 10)]
    out = trends(q, values)
    # The slope of sample k is known at sample k + 2, the trend of sample c at c + 6, when
    # c + 5 slopes have been seen: the first trend is that of sample MIN_SLOPES − 5.
    assert q.limits() is not None
    assert out[0][0] == float(MIN_SLOPES - 5)
    assert [c for c, _ in out] == [float(c) for c in range(MIN_SLOPES - 5, len(values) - 6)]
    low, high = q.limits() or (0.0, 0.0)
    assert low < 0 < high


def test_online_trends_agree_with_the_learner() -> None:
    """The learner's classification (global medians) and the online one agree."""
    rng = np.random.default_rng(3)
    times = np.cumsum(rng.uniform(0.045, 0.055, 4000))
    values = np.sin(times * 0.9) + 0.3 * np.sin(times * 2.9) + rng.normal(0, 0.005, times.size)
    ws = 0.5
    for integral in (False, True):
        q = QObs(ws, integral=integral)
        got: dict[float, int] = {}
        for t, v in zip(times.tolist(), values.tolist(), strict=True):
            got.update((c, int(tr)) for c, tr in q.push(t, v))
        row = np.cumsum(values) if integral else values
        lo, hi = window_bounds(times, ws / 2)
        s1 = windowed_slopes(times, row[None, :], lo, hi)
        s2 = windowed_slopes(times, s1, lo, hi)
        s3 = windowed_slopes(times, s2, lo, hi)
        reference = dict(zip(times.tolist(), classify(s1, s2, s3)[0].tolist(), strict=True))
        agree = np.mean([reference[c] == code for c, code in got.items()])
        assert len(got) > 3800
        assert agree > 0.95, (integral, agree)


def test_slopes_stay_exact_on_a_late_clock_and_a_large_integral() -> None:
    # Epoch-sized times and an integral that grows past 1e6: the moving origin keeps the
    # slope of v = 2t at 2 to many digits.
    s = SlidingSlope(0.5)
    base = 1.7e9
    out = []
    for k in range(5000):
        t = base + 0.01 * k
        out += s.push(t, 1e6 + 2.0 * (t - base))
    assert len(out) > 4000
    assert max(abs(slope - 2.0) for _, slope in out[10:]) < 1e-6


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


def feed_pair(spec: ObserverSpec, f1: list[float], f2: list[float]) -> list[Verdict]:
    obs = build(spec)
    out = []
    for t, (a, b) in enumerate(zip(f1, f2, strict=True)):
        out += obs.feed(Message(float(t), "/a", {"x": a}))
        out += obs.feed(Message(float(t), "/b", {"y": b}))
    return out


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
