"""Edge cases of the observers against Algorithms 1-8 (chapter 5 and its errata).

Each test feeds events straight to one observer: window edges, the exact comparison
operators, start-up, a topic or process that goes silent, non-finite values, several
statuses of one device in one /diagnostics array, constant and noisy trends.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rac.logic import Atom
from rac.observe import (
    DeviceStatus,
    Message,
    NodeSample,
    ObserverBank,
    PropertySample,
    Verdict,
    build,
)
from rac.observe.base import Observer
from rac.observe.dobs import violations_first
from rac.observe.qobs import QObs, Trend
from rac.passes.observers import ObserverSpec, ParamValue


def spec(kind: str, atom: Atom, **params: ParamValue) -> ObserverSpec:
    return ObserverSpec(kind, f"edge_{kind.lower()}", tuple(params.items()), (atom,))


def trace(verdicts: list[Verdict]) -> list[tuple[float, str]]:
    return [(v.t, str(v)) for v in verdicts]


def texts(verdicts: list[Verdict]) -> list[str]:
    return [str(v) for v in verdicts]


def twelve_digits(x: float) -> float:
    """A parameter as observers.yaml writes it (twelve significant digits)."""
    return float(f"{x:.12g}")


# -- GObs (Algorithm 1) ---------------------------------------------------------------------

OK_X = Atom("ok", ("x",))


# The text's Algorithm 1: no window floor, no hold, no silence floor, receive times only.
TEXT = {"min_window_s": 0.0, "min_count": 0, "hold_s": 0.0, "silence_s": 0.0, "stamps": False}


def gobs(delta: float, dev: float, ws: float, theta: int) -> Observer:
    return build(
        spec("GObs", OK_X, topic="/x", delta=delta, dev=dev, ws=ws, mismatch_th=theta, **TEXT)
    )


def feed_times(obs: Observer, times: list[float]) -> list[Verdict]:
    out = []
    for t in times:
        out += obs.feed(Message(t, "/x", {}))
    return out


def test_gobs_window_edge_belongs_to_the_window() -> None:
    # Line 5: O_mid − ω/2 ≤ O_i ≤ O_mid + ω/2.  With O_mid = 0 and ω = 1 an occurrence at
    # exactly 0.5 joins the window (no check); only 0.75 triggers the first check.
    obs = gobs(0.25, 0.05, 1.0, 0)
    assert feed_times(obs, [0.0, 0.25, 0.5]) == []
    assert trace(feed_times(obs, [0.75])) == [(0.75, "ok(x)")]


@pytest.mark.parametrize("interval", [0.125, 0.375])
def test_gobs_mean_interval_exactly_at_delta_plus_or_minus_sigma_is_ok(interval: float) -> None:
    # Line 10 (errata): |μ − δ| ≤ σ.  δ = 0.25, σ = 0.125, all exact in binary; θ = 0 so a
    # single violation would show.
    obs = gobs(0.25, 0.125, 1.0, 0)
    out = feed_times(obs, [interval * k for k in range(60)])
    assert texts(out) == ["ok(x)"]


def test_gobs_mean_interval_beyond_sigma_is_not_ok() -> None:
    obs = gobs(0.25, 0.125, 1.0, 0)
    out = feed_times(obs, [0.5 * k for k in range(20)])
    assert texts(out) == ["not_ok(x)"]


@pytest.mark.parametrize(
    ("rate", "tolerance", "start"),
    [(10.0, 1.0, 0.0), (30.0, 3.0, 0.0), (100.0, 10.0, 5000.0), (7.0, 0.7, 123.456)],
)
def test_gobs_rate_exactly_at_the_slow_edge_of_the_band_is_ok(
    rate: float, tolerance: float, start: float
) -> None:
    # The compiler's σ = 1/(RATE − TOL) − 1/RATE, written to twelve digits: a topic at exactly
    # RATE − TOL has |μ − δ| = σ, which the ≤ of line 10 accepts.  Rounding of σ and of the
    # timestamps must not turn the edge into a violation.
    delta = 1.0 / rate
    obs = gobs(
        twelve_digits(delta),
        twelve_digits(1.0 / (rate - tolerance) - delta),
        twelve_digits(10 * delta),
        0,
    )
    slow = rate - tolerance
    out = feed_times(obs, [start + k / slow for k in range(300)])
    assert texts(out) == ["ok(x)"]
    # Just beyond the band (2 % of the tolerance slower) reads not ok.
    obs = gobs(
        twelve_digits(delta),
        twelve_digits(1.0 / (rate - tolerance) - delta),
        twelve_digits(10 * delta),
        0,
    )
    slower = rate - 1.02 * tolerance
    out = feed_times(obs, [start + k / slower for k in range(300)])
    assert texts(out)[-1] == "not_ok(x)"


def test_gobs_topic_that_published_once_then_stopped_reads_not_ok() -> None:
    # One occurrence at 0: the window ends at E = 0.5.  Silent violations at
    # E + (k + ½)δ = 0.875, 1.125, 1.375: counts 1, 2 (the θ rule's first verdict is ok),
    # then 3 > θ = 2.
    obs = gobs(0.25, 0.05, 1.0, 2)
    out = feed_times(obs, [0.0])
    out += obs.advance(0.8)
    assert out == []
    out += obs.advance(5.0)
    assert trace(out) == [(0.875, "ok(x)"), (1.375, "not_ok(x)")]


def test_gobs_silence_is_counted_by_the_next_occurrence_without_advance() -> None:
    # No advance at all: the occurrence that ends the silence counts it first.
    obs = gobs(0.25, 0.05, 1.0, 2)
    out = feed_times(obs, [0.25 * k for k in range(8)])  # ok at 0.75; last at 1.75
    out += feed_times(obs, [10.0])
    assert texts(out) == ["ok(x)", "not_ok(x)"]


def test_gobs_duplicate_occurrences_count() -> None:
    # Every message twice (Definition 5.2 counts occurrences): twice the rate, not ok.
    obs = gobs(0.25, 0.05, 1.0, 2)
    out = feed_times(obs, [0.25 * (k // 2) for k in range(60)])
    assert texts(out) == ["ok(x)", "not_ok(x)"]


def test_gobs_advance_to_an_earlier_time_changes_nothing() -> None:
    obs = gobs(0.25, 0.05, 1.0, 2)
    out = feed_times(obs, [0.25 * k for k in range(8)])
    assert obs.advance(0.5) == []
    assert texts(out) == ["ok(x)"]


# -- NObs (Algorithm 2) ---------------------------------------------------------------------

RUNNING = Atom("running", ("n",))


def test_nobs_theta_zero_turns_at_once_both_ways() -> None:
    obs = build(spec("NObs", RUNNING, node="n", mismatch_th=0))
    out = []
    for t, running in enumerate([True, False, True, False, False, True]):
        out += obs.feed(NodeSample(float(t), "/n", running))
    assert texts(out) == [
        "running(n)",
        "not_running(n)",
        "running(n)",
        "not_running(n)",
        "running(n)",  # the count is bounded at 2θ + 1 = 1: one good sample clears it
    ]


# -- DObs (Algorithm 3) ---------------------------------------------------------------------

OK_DEV = Atom("ok", ("hokuyo",))


def dobs(theta: int) -> Observer:
    return build(spec("DObs", OK_DEV, topic="/diagnostics", device="hokuyo", mismatch_th=theta))


@pytest.mark.parametrize(
    ("level", "positive"), [(0, True), (1, True), (2, False), (3, False), (4, False), (-1, False)]
)
def test_dobs_each_level(level: int, positive: bool) -> None:
    # Line 4: OK and WARN satisfy the check; ERROR, STALE and anything else violate it.
    out = dobs(0).feed(DeviceStatus(1.0, "hokuyo", "", level))
    assert trace(out) == [(1.0, "ok(hokuyo)" if positive else "not_ok(hokuyo)")]


@pytest.mark.parametrize("order", [(0, 2), (2, 0), (1, 3, 0)])
def test_dobs_one_array_is_one_check_at_its_worst_level(order: tuple[int, ...]) -> None:
    # Line 3: one state of the device per occurrence of /diagnostics.  A driver that
    # reports the device in several statuses ("hokuyo: Connection" ERROR, "hokuyo:
    # Frequency" OK) is in error: its OK status must not cancel the ERROR one.
    arrays = [
        [DeviceStatus(t, f"hokuyo: part{i}", "", level) for i, level in enumerate(order)]
        for t in (1.0, 2.0, 3.0)
    ]
    # Arrays at 1 and 2 are one violation each (counts 1, 2 > θ = 1): not ok at 2, and the
    # array at 3 keeps it there.  The sources pass violations first: no verdict is revised.
    obs = dobs(1)
    out = [v for array in arrays for status in violations_first(array) for v in obs.feed(status)]
    assert trace(out) == [(1.0, "ok(hokuyo)"), (2.0, "not_ok(hokuyo)")]
    # In any order the verdict of each array comes out the same (an array whose good status
    # came first may revise it at the same time).
    obs = dobs(1)
    state, after = "", []
    for array in arrays:
        for status in array:
            for v in obs.feed(status):
                state = str(v)
        after.append(state)
    assert after == ["ok(hokuyo)", "not_ok(hokuyo)", "not_ok(hokuyo)"]


def test_dobs_a_good_array_after_bad_ones_recovers_by_one_check() -> None:
    obs = dobs(1)
    out = []
    for t, levels in ((1.0, (2, 2)), (2.0, (2, 0)), (3.0, (0, 0, 1)), (4.0, (0,))):
        for i, level in enumerate(levels):
            out += obs.feed(DeviceStatus(t, f"hokuyo: part{i}", "", level))
    # counts 1 (ok), 2 (not ok), 1 (ok: one good array is one check, not three), 0.
    assert trace(out) == [(1.0, "ok(hokuyo)"), (2.0, "not_ok(hokuyo)"), (3.0, "ok(hokuyo)")]


def test_dobs_silent_diagnostics_keep_the_last_verdict() -> None:
    # Algorithm 3 checks per occurrence only (the diagnostics aggregator marks a silent
    # device STALE itself): no time-out in the observer.
    obs = dobs(0)
    assert texts(obs.feed(DeviceStatus(1.0, "hokuyo", "", 0))) == ["ok(hokuyo)"]
    assert obs.advance(1e6) == []


# -- PObs (Algorithm 7) ---------------------------------------------------------------------

OK_CPU = Atom("ok", ("n", "cpu"))


def pobs(theta: int, max_val: float = 10.0) -> Observer:
    return build(spec("PObs", OK_CPU, node="n", property="cpu", max_val=max_val, mismatch_th=theta))


def test_pobs_mean_exactly_at_the_limit_is_ok() -> None:
    # Line 8: μ ≤ v_max.
    obs = pobs(0, 10.0)
    out = []
    for t in range(30):
        out += obs.feed(PropertySample(float(t), "n", "cpu", 10.0))
    assert texts(out) == ["ok(n,cpu)"]
    assert texts(obs.feed(PropertySample(30.0, "n", "cpu", 10.5))) == ["not_ok(n,cpu)"]


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_pobs_skips_a_non_finite_sample(bad: float) -> None:
    # A sample that is not a number is no measurement: it must not sit in the queue for the
    # next ten samples.
    obs = pobs(0)
    out = obs.feed(PropertySample(0.0, "n", "cpu", 5.0))
    out += obs.feed(PropertySample(1.0, "n", "cpu", bad))
    for t in range(2, 12):
        out += obs.feed(PropertySample(float(t), "n", "cpu", 5.0))
    assert trace(out) == [(0.0, "ok(n,cpu)")]


def test_pobs_process_gone_keeps_the_last_verdict() -> None:
    # Line 3 (while isRunning(η)): no samples while the node is down, so no checks; NObs
    # reports the crash.  The queue carries over to the restarted process.
    obs = pobs(0)
    out = []
    for t in range(12):
        out += obs.feed(PropertySample(float(t), "n", "cpu", 50.0))
    assert texts(out) == ["ok(n,cpu)", "not_ok(n,cpu)"]  # the zeros delay the overload
    assert obs.advance(1000.0) == []
    assert obs.feed(NodeSample(1000.0, "n", False)) == []
    back = []
    for t in range(1001, 1012):
        back += obs.feed(PropertySample(float(t), "n", "cpu", 1.0))
    # The old samples leave one by one: after k low ones the mean is (50(10 − k) + k)/10,
    # 17.2 at k = 8 and 5.9 at k = 9.
    assert trace(back) == [(1009.0, "ok(n,cpu)")]


# -- IObs (Algorithm 8) ---------------------------------------------------------------------

EQUAL = Atom("equal", ("a", "x", "b", "y"))


def iobs(max_diff: float, theta: int = 0) -> Observer:
    return build(
        spec(
            "IObs",
            EQUAL,
            topic1="/a",
            field1="x",
            topic2="/b",
            field2="y",
            max_diff=max_diff,
            mismatch_th=theta,
        )
    )


@pytest.mark.parametrize(
    ("v1", "v2", "max_diff"),
    [(0.75, 0.5, 0.25), (1.1, 1.0, 0.1), (0.3, 0.2, 0.1), (-0.05, 0.0, 0.05), (10.7, 10.4, 0.3)],
)
def test_iobs_difference_exactly_at_the_bound_is_equal(
    v1: float, v2: float, max_diff: float
) -> None:
    # Line 5: |v1 − v2| ≤ Δ, for the decimal values the model and the messages write.
    obs = iobs(max_diff)
    out = obs.feed(Message(0.0, "/a", {"x": v1}))
    out += obs.feed(Message(0.1, "/b", {"y": v2}))
    assert texts(out) == ["equal(a,x,b,y)"]


def test_iobs_difference_beyond_the_bound_is_not_equal() -> None:
    obs = iobs(0.1)
    out = obs.feed(Message(0.0, "/a", {"x": 1.1}))
    out += obs.feed(Message(0.1, "/b", {"y": 0.9999}))
    assert texts(out) == ["not_equal(a,x,b,y)"]


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_iobs_skips_non_finite_values(bad: float) -> None:
    obs = iobs(0.1)
    out = obs.feed(Message(0.0, "/a", {"x": 1.0}))
    out += obs.feed(Message(0.1, "/b", {"y": 1.05}))
    out += obs.feed(Message(0.2, "/a", {"x": bad}))  # skipped: no check, 1.0 still stands
    out += obs.feed(Message(0.3, "/b", {"y": 1.02}))
    assert trace(out) == [(0.1, "equal(a,x,b,y)")]


# -- QObs and BiQObs (Algorithms 4 and 5) ---------------------------------------------------


def decided(q: QObs, times: np.ndarray, values: np.ndarray) -> list[Trend]:
    out = []
    for t, v in zip(times.tolist(), values.tolist(), strict=True):
        out += q.push(t, v)
    return [trend for _, trend in out]


def test_qobs_a_perfectly_constant_signal_is_constant() -> None:
    # Its slopes and their standard errors are all 0, so the online limit is 0: the
    # derivatives (0) lie within [−0, 0] and the trend is constant, not "the previous".
    times = np.arange(0.0, 20.0, 0.01)
    got = decided(QObs(1.0), times, np.full(times.size, 3.25))
    assert got and set(got) == {Trend.CONS}


def test_qobs_constant_after_a_ramp_is_constant() -> None:
    times = np.arange(0.0, 40.0, 0.01)
    values = np.minimum(times, 20.0)  # rises 1/s for 20 s, then flat
    q = QObs(1.0)
    out = []
    for t, v in zip(times.tolist(), values.tolist(), strict=True):
        out += q.push(t, v)
    assert {tr for c, tr in out if 12.0 <= c <= 19.0} == {Trend.INC}
    assert {tr for c, tr in out if c >= 22.0} == {Trend.CONS}


def test_qobs_integrated_side_skips_nothing_and_never_resets() -> None:
    # I(f) is the running sum of the samples since the start; a silence does not reset it,
    # so a constant positive rate keeps its sum rising across the gap.
    times = np.concatenate([np.arange(0.0, 20.0, 0.1), np.arange(30.0, 45.0, 0.1)])
    q = QObs(1.0, integral=True)
    out = []
    for t in times.tolist():
        out += q.push(t, 0.5)
    after = {tr for c, tr in out if c >= 32.0}
    assert after == {Trend.INC}
    assert q.latest_slope == pytest.approx(5.0)  # 0.5 per sample at 10 Hz


def biq(**extra: ParamValue) -> ObserverSpec:
    params: dict[str, ParamValue] = {
        "topic1": "/a",
        "field1": "x",
        "topic2": "/b",
        "field2": "y",
        "mismatch_th": 3,
        "ws": 1.0,
    }
    params.update(extra)
    return spec("BiQObs", Atom("matched", ("a", "x", "b", "y")), **params)


def feed_pair(
    obs: Observer, times: np.ndarray, a: np.ndarray, b: np.ndarray, every: int = 1
) -> list[Verdict]:
    out = []
    for i, t in enumerate(times.tolist()):
        out += obs.feed(Message(t, "/a", {"x": float(a[i])}))
        if i % every == 0:
            out += obs.feed(Message(t, "/b", {"y": float(b[i])}))
    return out


def test_biqobs_constant_against_noisy_flat_says_nothing() -> None:
    # Both sides rest (the noise is within the noisy side's limits): no verdict either way.
    rng = np.random.default_rng(3)
    times = np.arange(0.0, 40.0, 0.01)
    out = feed_pair(build(biq()), times, np.zeros(times.size), rng.normal(0, 0.05, times.size))
    assert texts(out) == []


def test_biqobs_constant_against_a_ramp_is_not_matched() -> None:
    times = np.arange(0.0, 40.0, 0.01)
    ramp = np.where(times > 20.0, times - 20.0, 0.0)
    out = feed_pair(build(biq()), times, np.zeros(times.size), ramp)
    assert texts(out)[-1] == "not_matched(a,x,b,y)"
    assert 20.0 < out[-1].t <= 26.0


def test_biqobs_counts_no_mismatch_while_the_moving_side_has_shown_only_noise() -> None:
    # A robot standing still from the start: a gyro's noise integrated (a random walk, whose
    # slopes pass its significance test) beside a flat heading.  Until the integrated side
    # has been seen moving, its "trends" may be its noise: no mismatch is counted.
    rng = np.random.default_rng(5)
    times = np.arange(0.0, 90.0, 0.02)
    out = feed_pair(
        build(biq(integral1=True)), times, rng.normal(0, 0.01, times.size), np.zeros(times.size)
    )
    assert "not_matched(a,x,b,y)" not in texts(out)


def test_biqobs_integrated_side_ignores_non_finite_values() -> None:
    # A NaN or inf in I(y) is skipped, not summed: the sum would stay NaN for good.
    times = np.arange(0.0, 30.0, 0.01)
    y = np.full(times.size, 0.2)
    y[500::700] = np.nan
    y[800::900] = np.inf
    out = feed_pair(build(biq(integral2=True)), times, times.copy(), y)
    assert texts(out) == ["matched(a,x,b,y)"]


def test_biqobs_side_that_stops_stops_the_checks() -> None:
    # Algorithm 5 asks both QObs for a trend; a side with no new samples has none for the
    # current time, so the verdict stays as it was (GObs reports the silent topic).
    times = np.arange(0.0, 30.0, 0.01)
    obs = build(biq())
    out = feed_pair(obs, times, times.copy(), times.copy())
    assert texts(out) == ["matched(a,x,b,y)"]
    more = []
    for t in np.arange(30.0, 60.0, 0.01).tolist():
        more += obs.feed(Message(t, "/a", {"x": -t}))  # side 1 turns; side 2 is silent
    more += obs.advance(100.0)
    # Until side 1's recent trends no longer reach back to side 2's last one, the checks
    # compare the same pair (both rising); then there is nothing to compare.
    assert more == []


# -- the bank -------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_bank_ignores_a_time_that_is_not_finite(bad: float) -> None:
    # GObs counts silence up to a time and BiQObs steps its grid to it: NaN or infinity
    # raised there (and would poison a regression's sums); the bank drops such an event.
    bank = ObserverBank(
        [
            spec("GObs", OK_X, topic="/x", delta=0.25, dev=0.05, ws=1.0, mismatch_th=2),
            biq(topic1="/x", topic2="/x"),
        ]
    )
    out = []
    for k in range(8):
        out += bank.feed(Message(0.25 * k, "/x", {"x": 1.0, "y": 2.0}))
    assert texts(out) == ["ok(x)"]
    assert bank.feed(Message(bad, "/x", {"x": 1.0, "y": 2.0})) == []
    assert bank.advance(bad) == []
    out = []
    for k in range(8, 12):
        out += bank.feed(Message(0.25 * k, "/x", {"x": 1.0, "y": 2.0}))
    assert out == []
