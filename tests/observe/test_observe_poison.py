"""No value poisons an observer (issue 34): sums, integrals and slopes stay finite and exact
again within a window after any value: huge, not finite, stamps from 1970 or the future.

A value beyond its field's plausible magnitude is evidence about its publisher for that
window (a relation's checks count it as violated), nothing more: once it has left the
window, the observer says what an observer that never saw it says.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rac.logic import Atom
from rac.observe import Message, Verdict, build
from rac.observe.gobs import GObs
from rac.observe.plausible import GENERIC_BOUND, bound, plausible
from rac.observe.qobs import QObs, SlidingSlope
from rac.passes.observers import ObserverSpec, ParamValue

MATCHED = Atom("matched", ("a", "x", "b", "y"))
EQUAL = Atom("equal", ("a", "x", "b", "y"))
OK = Atom("ok", ("x",))


def least_squares(window: list[tuple[float, float]]) -> tuple[float, float]:
    """The slope of a window and its standard error, computed afresh."""
    t = np.array([p[0] for p in window])
    v = np.array([p[1] for p in window])
    slope, intercept = np.polyfit(t, v, 1)
    residual = v - (slope * t + intercept)
    sxx = float(((t - t.mean()) ** 2).sum())
    return float(slope), math.sqrt(float((residual**2).sum()) / (len(t) - 2) / sxx)


def test_a_spike_leaves_the_sliding_slope_exact_once_it_has_left_its_window() -> None:
    # v = 2t + noise at 100 Hz with one spike of 1e9 (plausible for a generic field): once
    # the spike has left the window, slope and standard error are those of an observer that
    # never saw it, to many digits.  Subtracting 1e18 from the sum of squares would leave a
    # residue of about 100 in it, and a standard error of garbage.
    rng = np.random.default_rng(3)
    spiked, clean = SlidingSlope(0.5), SlidingSlope(0.5)
    out, want = [], []
    for k in range(600):
        t = 0.01 * k
        v = 2.0 * t + rng.normal(0.0, 0.01)
        out += spiked.push(t, v + (1e9 if k == 100 else 0.0))
        want += clean.push(t, v)
    after = [(got, exact) for got, exact in zip(out, want, strict=True) if got[0] > 1.5 + 0.01]
    assert len(after) > 350
    for (_, slope, se), (_, want_slope, want_se) in after:
        assert slope == pytest.approx(want_slope, rel=1e-9)
        assert se == pytest.approx(want_se, rel=1e-6)


def test_the_sliding_slope_matches_least_squares_after_a_spike() -> None:
    rng = np.random.default_rng(4)
    s = SlidingSlope(0.5)
    samples: list[tuple[float, float]] = []
    out = []
    for k in range(300):
        t = k / 64  # exact binary times: the window's edges are not a matter of rounding
        v = -0.5 * t + rng.normal(0.0, 0.02) + (3e11 if k == 40 else 0.0)
        samples.append((t, v))
        out += s.push(t, v)
    checked = 0
    for centre, slope, se in out:
        if centre <= 40 / 64 + 0.5:
            continue
        want_slope, want_se = least_squares([p for p in samples if abs(p[0] - centre) <= 0.5])
        assert slope == pytest.approx(want_slope, rel=1e-9)
        assert se == pytest.approx(want_se, rel=1e-6)
        checked += 1
    assert checked > 150


@pytest.mark.parametrize("glitch", [1e308, -1e308, 1e20, math.inf, math.nan])
def test_a_huge_or_non_finite_value_never_enters_the_sums(glitch: float) -> None:
    # A refused value leaves nothing behind: the observer that saw 8 s of the glitch gives
    # every trend after it exactly as one that received nothing in those 8 s.  (One that
    # received the true signal meanwhile differs a little, and rightly: it learned 8 s
    # more of the signal's slopes, which its noise band is measured from.)
    def trace(glitch: float | None) -> list[tuple[float, int]]:
        q = QObs(1.0)
        out = []
        rng = np.random.default_rng(1)
        for k in range(3000):
            t = 0.01 * k
            v = math.sin(t / 3.0) + rng.normal(0.0, 0.01)
            if 1000 <= k < 1800:  # 8 s of it, as the attack on /pose
                if glitch is None:
                    continue
                v = glitch
            out += [(c, int(tr)) for c, tr in q.push(t, v)]
        assert all(math.isfinite(c) for c, _ in out)
        return out

    clean = dict(trace(None))
    dirty = dict(trace(glitch))
    after = [c for c in dirty if c > 18.0]
    assert len(after) > 800
    assert [dirty[c] for c in after] == [clean.get(c) for c in after]


def test_an_integral_is_not_frozen_by_a_large_value() -> None:
    # I(y) of y = 0.01 at 100 Hz rises at 1/s.  A stream of large but plausible values
    # (1e12) first lifts the integral to 1e14: beyond 2^53 × 0.01 an increment of 0.01
    # would vanish, and the integral's slope would read 0 for good.
    q = QObs(1.0, integral=True, slope=0.1)
    out = []
    for k in range(4000):
        t = 0.01 * k
        v = 1e12 if k < 100 else 0.01
        out += q.push(t, v)
    assert q.latest_slope == pytest.approx(1.0, rel=1e-6)
    assert out[-1][1] == 2  # increasing


def field_spec(kind: str, atom: Atom, **params: ParamValue) -> ObserverSpec:
    base: dict[str, ParamValue] = {"topic1": "/a", "field1": "x", "topic2": "/b", "field2": "y"}
    base.update(params)
    return ObserverSpec(kind, "pair_obs", tuple(base.items()), (atom,))


def biqobs_trace(glitch: float | None, start: float, end: float) -> list[tuple[float, str]]:
    """Two copies of one heading at 50 Hz for 90 s; side 1 carries ``glitch`` in [start,
    end)."""
    obs = build(field_spec("BiQObs", MATCHED))
    rng = np.random.default_rng(5)
    out: list[Verdict] = []
    for k in range(4500):
        t = 0.02 * k
        heading = 0.3 * math.sin(t / 4.0)
        a = heading + rng.normal(0.0, 0.005)
        if glitch is not None and start <= t < end:
            a = glitch
        out += obs.feed(Message(t, "/a", {"x": a}))
        out += obs.feed(Message(t, "/b", {"y": heading + rng.normal(0.0, 0.005)}))
    return [(v.t, str(v)) for v in out]


@pytest.mark.parametrize("glitch", [1e308, 1e20])
def test_a_relation_broken_by_huge_values_recovers_within_its_window(glitch: float) -> None:
    assert biqobs_trace(None, 0.0, 0.0) == [(10.5, "matched(a,x,b,y)")]
    out = biqobs_trace(glitch, 30.0, 38.0)
    # 8 s of garbage from side 1's publisher is evidence against the pair for that time...
    broken = [t for t, text in out if text.startswith("not_")]
    assert broken and 30.0 <= broken[0] <= 34.0
    # ... and nothing more: matched again soon after, and for good.
    assert out[-1][1] == "matched(a,x,b,y)"
    assert out[-1][0] <= 38.0 + 5.0


def test_a_single_huge_value_changes_no_relation() -> None:
    out = biqobs_trace(1e308, 40.0, 40.02)
    assert out == [(10.5, "matched(a,x,b,y)")]


def test_an_interval_check_counts_a_huge_value_once_and_keeps_nothing_of_it() -> None:
    obs = build(field_spec("IObs", EQUAL, max_diff=0.5, mismatch_th=2))
    out: list[Verdict] = []
    for k in range(40):
        t = float(k)
        a = 1e200 if 10 <= k < 12 else 1.0
        out += obs.feed(Message(t, "/a", {"x": a}))
        out += obs.feed(Message(t + 0.5, "/b", {"y": 1.2}))
    # Two checks failed (θ = 2: still equal); the next message of side 2 is compared with
    # side 1's last plausible value, not with 1e200.
    assert [str(v) for v in out] == ["equal(a,x,b,y)"]
    burst: list[Verdict] = []
    for k in range(40, 60):
        burst += obs.feed(Message(float(k), "/a", {"x": 1e200}))
    assert [str(v) for v in burst] == ["not_equal(a,x,b,y)"]
    tail: list[Verdict] = []
    for k in range(60, 70):
        tail += obs.feed(Message(float(k), "/a", {"x": 1.0}))
    assert [str(v) for v in tail] == ["equal(a,x,b,y)"]


def gobs(rate: float) -> GObs:
    delta = 1.0 / rate
    params: tuple[tuple[str, ParamValue], ...] = (
        ("topic", "/x"),
        ("delta", delta),
        ("dev", 1.0 / (0.9 * rate) - delta),
        ("ws", 10 * delta),
        ("mismatch_th", 5),
    )
    obs = build(ObserverSpec("GObs", "x_gobs", params, (OK,)))
    assert isinstance(obs, GObs)
    return obs


@pytest.mark.parametrize("wild", [1.0, 1e-6, 4.2e9, 1.78e9 + 3600.0, 1.78e9 - 3600.0])
def test_one_wild_stamp_makes_no_frequency_fault(wild: float) -> None:
    # A 50 Hz topic stamped today; one message carries a stamp from 1970, from an hour
    # before or after, or near the end of 32-bit time.  Its window is timed by receive time.
    obs = gobs(50.0)
    out: list[Verdict] = []
    tick = 0.1
    for k in range(50 * 60):
        t = k / 50.0
        while tick <= t:
            out += obs.advance(tick)
            tick = round(tick + 0.1, 9)
        stamp = wild if k == 1500 else 1.78e9 + t
        out += obs.feed(Message(t, "/x", {}, stamp))
    assert [str(v) for v in out] == ["ok(x)"]


def test_plausible_bounds_follow_the_fields_units() -> None:
    assert bound("twist.twist.angular.z") == 1e4
    assert bound("angular_velocity.z") == 1e4
    assert bound("linear_acceleration.y") == 1e4
    assert bound("pose.pose.orientation.w") == 1.5
    assert bound("pose.pose.position.x") == 1e9
    assert bound("yaw") == GENERIC_BOUND
    assert plausible(-1e4, 1e4) and not plausible(1.0001e4, 1e4)
    assert not plausible(math.nan, 1e4) and not plausible(math.inf, GENERIC_BOUND)
