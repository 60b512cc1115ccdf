"""Unit tests of the learning steps: trends, Table 9.1, matching, rates, inputs."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

from rac.errors import RacError
from rac.learn.correlate import (
    COUNTED,
    MATCHED,
    STATES,
    TABLE,
    PairEvidence,
    TrendSet,
    chance,
    interpolate,
    pooled,
)
from rac.learn.frequency import GAP_FACTOR, Histogram, TopicRates, rate_stats, topic_rates
from rac.learn.graph import parse_graph
from rac.learn.properties import parse_properties, property_stats
from rac.learn.recording import Run, TopicData, merge_runs
from rac.learn.trends import CONSTANT, DECREASING, INCREASING, Signal, TopicTrends, topic_trends

D, C, UP = DECREASING, CONSTANT, INCREASING


def _topic(
    name: str, times: np.ndarray, stamps: np.ndarray | None = None, **fields: np.ndarray
) -> TopicData:
    values = np.array([fields[f] for f in fields], dtype=np.float64).reshape(
        len(fields), times.size
    )
    return TopicData(
        name,
        "std_msgs/Float64",
        (),
        times,
        np.zeros(times.size, dtype=np.int64),
        tuple(fields),
        values,
        stamps,
    )


def test_trends_of_a_rise_a_plateau_and_a_fall() -> None:
    t = np.arange(0.0, 30.0, 0.1)
    # Up for 10 s, flat for 10 s, down for 10 s, at varying speeds.
    speed = 1 + 0.5 * np.sin(t)
    rate = np.where(t < 10, speed, np.where(t < 20, 0.0, -speed))
    v = np.cumsum(rate) * 0.1
    trends = topic_trends(_topic("/x", t, v=v), occurrences=10, integrate=False)
    assert trends is not None
    codes = trends.codes[0]
    assert np.mean(codes[10:90] == UP) > 0.9
    assert np.mean(codes[110:190] == C) > 0.9
    assert np.mean(codes[210:290] == D) > 0.9
    # The plateau rests; the rise and the fall do not.
    assert trends.rest[0][115:185].all() and not trends.rest[0][20:80].any()


def test_a_window_is_at_least_the_observers_second() -> None:
    # At 50 Hz, C = 10 occurrences are 0.2 s: the relation's observer never regresses over
    # less than a second, so neither does learning.
    t = np.arange(0.0, 20.0, 0.02)
    trends = topic_trends(_topic("/x", t, v=np.sin(t)), 10)
    assert trends is not None and trends.window_s == 1.0


def test_constant_fields_have_no_trends() -> None:
    t = np.arange(0.0, 10.0, 0.1)
    assert topic_trends(_topic("/x", t, v=np.full(t.size, 3.0)), 10) is None


def test_integrated_signal_rises_while_the_raw_one_is_positive() -> None:
    t = np.arange(0.0, 20.0, 0.1)
    v = np.where(t < 10, 1.0, -1.0) + 0.01 * np.sin(7 * t)
    trends = topic_trends(_topic("/x", t, v=v), 10)
    assert trends is not None
    assert [s.integrated for s in trends.signals] == [False, True]
    integrated = trends.codes[1]
    assert np.mean(integrated[10:90] == UP) > 0.45
    assert np.mean(integrated[110:190] == D) > 0.45


def test_a_heading_that_wanders_at_rest_rests() -> None:
    # Half of the time turning at 0.5 rad/s, half standing still while the heading wanders
    # ±0.05 rad (magnetometer noise): the wander is within the signal's noise band.
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 600.0, 0.02)
    moving = (t // 20) % 2 == 0
    rate = np.where(moving, 0.5 * np.sign(np.sin(t / 40 * np.pi) + 0.1), 0.0)
    noise = np.convolve(rng.normal(size=t.size + 100), np.ones(100) / 100, mode="valid")
    wander = 0.05 * noise[: t.size] / np.abs(noise).max() * ~moving
    yaw = np.cumsum(rate) * 0.02 + wander
    trends = topic_trends(_topic("/imu", t, yaw=yaw), 10, integrate=False)
    assert trends is not None
    still = ~moving & (t % 20 > 3) & (t % 20 < 17)
    assert trends.bands[0] > 0.05
    assert trends.rest[0][still].mean() > 0.95
    assert not trends.rest[0][moving & (t % 20 > 3) & (t % 20 < 17)].any()


@pytest.mark.parametrize(
    ("corners", "expected"),
    [
        ((D, D), (D, D, D, D)),
        ((D, UP), (D, C, C, UP)),
        ((UP, C), (UP, UP, C, C)),
        ((C, D), (C, C, D, D)),
        ((UP, D), (UP, C, C, D)),
    ],
)
def test_table_9_1(corners: tuple[int, int], expected: tuple[int, ...]) -> None:
    assert tuple(TABLE[corners[0], corners[1]].tolist()) == expected


def _trends(
    name: str, times: np.ndarray, codes: list[list[int]], rest: list[list[bool]] | None = None
) -> TopicTrends:
    signals = tuple(Signal(name, f"f{i}", False) for i in range(len(codes)))
    array = np.array(codes, dtype=np.int8)
    resting = np.zeros(array.shape, dtype=bool) if rest is None else np.array(rest, dtype=bool)
    zeros = np.zeros(len(codes))
    return TopicTrends(name, times, signals, array, resting, 1.0, zeros, zeros)


def test_interpolation_uses_the_zones_between_neighbours() -> None:
    other = _trends("/b", np.array([0.0, 1.0]), [[D, UP]])
    times = np.array([-0.5, 0.1, 0.4, 0.6, 0.9, 1.5])
    codes, inside = interpolate(times, other)
    assert inside == 4
    assert codes[0, 1:5].tolist() == [D, C, C, UP]
    assert codes[0, 0] == codes[0, 5] == 3  # outside the span: never matches


def test_interpolation_beyond_a_span_ending_in_two_messages_of_one_stamp_is_quiet() -> None:
    """The clipped neighbours of a time past the end may share a stamp: no division by zero
    (numpy's RuntimeWarning is an error here), and the time is outside."""
    other = _trends("/b", np.array([0.0, 1.0, 1.0]), [[D, UP, UP]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        codes, inside = interpolate(np.array([0.5, 2.0]), other)
    assert inside == 1
    assert codes[0].tolist() == [C, 3]


def test_evidence_counts_both_directions_and_only_checks_where_a_side_moves() -> None:
    rng = np.random.default_rng(1)
    ta, tb = np.sort(rng.uniform(0, 10, 50)), np.sort(rng.uniform(0, 10, 70))
    a = _trends(
        "/a", ta, rng.integers(0, 3, (1, 50)).tolist(), (rng.random((1, 50)) < 0.4).tolist()
    )
    b = _trends(
        "/b", tb, rng.integers(0, 3, (1, 70)).tolist(), (rng.random((1, 70)) < 0.4).tolist()
    )
    (found,) = TrendSet({"/a": a, "/b": b}).evidence([(a.signals[0], b.signals[0])])
    assert found is not None
    b_at_a, _ = interpolate(ta, b)
    a_at_b, _ = interpolate(tb, a)
    rest_b = b.rest[0][np.clip(np.searchsorted(tb, ta, side="right") - 1, 0, None)]
    rest_a = a.rest[0][np.clip(np.searchsorted(ta, tb, side="right") - 1, 0, None)]
    inside_a, inside_b = b_at_a[0] != 3, a_at_b[0] != 3
    counted_a = inside_a & ~(a.rest[0] & rest_b)
    counted_b = inside_b & ~(b.rest[0] & rest_a)
    assert found.checks == counted_a.sum() + counted_b.sum()
    # A resting sample compares as constant.
    own_a, other_a = np.where(a.rest[0], C, a.codes[0]), np.where(rest_b, C, b_at_a[0])
    own_b, other_b = np.where(b.rest[0], C, b.codes[0]), np.where(rest_a, C, a_at_b[0])
    matched = (counted_a & (own_a == other_a)).sum() + (counted_b & (own_b == other_b)).sum()
    assert found.matches == matched


def test_chance_leaves_out_what_rests_on_both_sides() -> None:
    # Both always rest: nothing is ever checked.
    resting = np.zeros(STATES)
    resting[2 * C + 1] = 1.0
    assert chance(resting, resting) == 0.0
    # Two signals that move half of the time, each trend equally likely.
    half = np.zeros(STATES)
    half[[2 * D, 2 * C, 2 * UP]] = 1 / 6
    half[2 * C + 1] = 1 / 2
    assert COUNTED.shape == MATCHED.shape == (STATES, STATES)
    assert 0 < chance(half, half) < 0.5


def test_persistent_trends_count_as_few_independent_checks() -> None:
    # Two independent signals whose trends hold for 5 s at a time: 3000 checks of 60 s at
    # 50 Hz are about a dozen independent ones.
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 60.0, 0.02)

    def persistent() -> list[list[int]]:
        runs = rng.integers(0, 3, 12)
        return [np.repeat(runs, t.size // 12 + 1)[: t.size].tolist()]

    a, b = _trends("/a", t, persistent()), _trends("/b", t + 0.001, persistent())
    (found,) = TrendSet({"/a": a, "/b": b}).evidence([(a.signals[0], b.signals[0])])
    assert found is not None and found.checks > 5000
    assert 3 < found.effective < 60


def test_the_z_test_holds_its_level_on_autocorrelated_independent_signals() -> None:
    # 200 pairs of independent signals with persistent trends: at p < 0.05 about 5 % may be
    # "significant"; counting every sample as independent made most of them so.
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 120.0, 0.05)
    significant = 0
    for _ in range(200):
        a = _trends("/a", t, [np.repeat(rng.integers(0, 3, 40), 60)[: t.size].tolist()])
        b = _trends("/b", t + 0.01, [np.repeat(rng.integers(0, 3, 40), 60)[: t.size].tolist()])
        (e,) = TrendSet({"/a": a, "/b": b}).evidence([(a.signals[0], b.signals[0])])
        assert e is not None
        significant += pooled([e]).p < 0.05
    assert significant <= 20


def test_pooled_evidence_adds_counts_and_variances() -> None:
    one = PairEvidence(90, 100, 0.4, 100 * 0.24 * 5)
    two = PairEvidence(80, 100, 0.5, 100 * 0.25 * 5)
    both = pooled([one, two])
    assert both.ratio == pytest.approx(0.85) and both.chance == pytest.approx(0.45)
    assert both.z == pytest.approx((170 - 90) / np.sqrt(100 * 0.24 * 5 + 100 * 0.25 * 5))
    assert pooled([PairEvidence(10, 10, 1.0, 0.0)]).effective == 0.0  # chance explains all


def _rates(topic: TopicData, blocks: int = 1) -> TopicRates:
    start, end = float(topic.times[0]), float(topic.times[-1]) + 1e-9
    edges = np.linspace(start, end, blocks + 1)
    spans = [(0, float(a), float(b)) for a, b in itertools.pairwise(edges.tolist())]
    found = topic_rates(topic, spans, None)
    assert found is not None
    return found


def test_regularity_is_median_over_robust_sigma_above_alpha() -> None:
    rng = np.random.default_rng(2)
    steady = np.arange(0, 100, 0.1) + rng.normal(0, 0.002, 1000)
    bursty = np.cumsum(rng.exponential(0.1, 1000))
    for alpha in (10, 0.5):
        stats = rate_stats(_rates(_topic("/s", steady)), alpha)
        assert stats is not None and stats.regular
        assert stats.rate_hz == pytest.approx(10, rel=0.01)
        assert 0 < stats.tolerance_hz < 1
    assert not rate_stats(_rates(_topic("/b", bursty)), 2.5).regular  # type: ignore[union-attr]
    assert rate_stats(_rates(_topic("/b", bursty)), 0.2).regular  # type: ignore[union-attr]
    assert topic_rates(_topic("/few", np.array([0.0, 1.0])), [(0, 0.0, 2.0)], None) is None


def test_a_steady_imu_with_dropouts_learns_its_rate() -> None:
    # 50 Hz for 92 s with 24 dropouts of 0.1-0.3 s (the AR.Drone's IMU): mean/σ of the
    # intervals is below 1, yet its rate is 50 Hz and it is regular.
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 92.0, 0.02) + rng.normal(0, 0.0005, 4600)
    for start in rng.uniform(1, 90, 24):
        t = t[(t < start) | (t > start + rng.uniform(0.1, 0.3))]
    deltas = np.diff(t)
    assert deltas.mean() / deltas.std() < 2.5  # Algorithm 15's rule: irregular
    stats = rate_stats(_rates(_topic("/imu", t), 4), 2.5)
    assert stats is not None and stats.regular
    assert stats.rate_hz == pytest.approx(50.0, rel=0.005)
    assert stats.gaps >= 20 and stats.gap_s > 2.0
    assert abs((deltas > GAP_FACTOR * 0.02).sum() - stats.gaps) <= 1


def test_bursty_arrivals_are_timed_by_their_header_stamps() -> None:
    # A 50 Hz publisher whose messages arrive two at a time: the receive times say nothing
    # regular (median 0 or 40 ms), the stamps say 50 Hz.
    stamps = 1000.0 + np.arange(3000) * 0.02
    received = stamps + np.where(np.arange(3000) % 2 == 0, 0.02, 0.0) + 0.005
    stats = rate_stats(_rates(_topic("/odom", received - 1000.0, stamps, v=np.sin(stamps))), 2.5)
    assert stats is not None and stats.stamped and stats.regular
    assert stats.rate_hz == pytest.approx(50.0, rel=1e-3)
    plain = rate_stats(_rates(_topic("/odom", received - 1000.0, None)), 2.5)
    assert plain is not None and not plain.regular and not plain.stamped


def test_histograms_merge_and_keep_exact_values() -> None:
    a = Histogram.of(np.full(10, 0.01))
    b = Histogram.of(np.array([0.01, 0.02, 0.02]))
    both = a + b
    assert both.count == 13
    assert both.quantile(0.5) == pytest.approx(0.01, rel=1e-12)  # a bin's mean
    assert (a + b).bins == (b + a).bins


def test_algorithm_19_shifts_each_run_to_the_end_of_the_previous() -> None:
    def run(path: str, start: float, n: int) -> Run:
        times = start + np.arange(n, dtype=np.float64)
        topic = _topic("/x", times, v=np.arange(n, dtype=np.float64))
        return Run(path, 1, float(times[0]), float(times[-1]), (topic,), n)

    merged = merge_runs([run("a", 1000.0, 10), run("b", 5000.0, 5)])
    x = merged.topic_by_name()["/x"]
    assert x.times.tolist() == [*range(10), *range(9, 14)]
    assert x.segments.tolist() == [0] * 10 + [1] * 5
    assert x.intervals().tolist() == [1.0] * 13  # the seam is left out


def test_graph_accepts_rosnode_info_lines_and_rejects_unknown_keys() -> None:
    graph = parse_graph(
        "nodes:\n  /a:\n    publications: ['* /x [std_msgs/Int8]', /rosout]\n"
        "    subscribers: [/y]\n",
        "g.yaml",
    )
    assert graph.nodes[0].name == "a"
    assert graph.nodes[0].publications == ("/x",)
    assert graph.nodes[0].subscriptions == ("/y",)
    for bad in ("[]", "nodes: {a: {talks: [/x]}}", "nodes: {}\nextra: 1", "nodes: {a: 3}"):
        with pytest.raises(RacError) as err:
            parse_graph(bad, "g.yaml")
        assert err.value.diagnostics[0].code == "RAC081"


def test_graph_accepts_ros2_node_info_lines_and_checks_hardware_types() -> None:
    graph = parse_graph(
        "nodes:\n  /a:\n"
        "    publishers: ['/x: std_msgs/msg/Int8', '/rosout: rcl_interfaces/msg/Log']\n"
        "    subscribers: ['/y: std_msgs/msg/Int8']\n",
        "g.yaml",
    )
    assert graph.nodes[0].publications == ("/x",)
    assert graph.nodes[0].subscriptions == ("/y",)
    for bad in ("{switchable: true, channel: true}", "{switchable: 'no'}"):
        with pytest.raises(RacError) as err:
            parse_graph(f"nodes: {{a: {{drives: [h]}}}}\nhardware: {{h: {bad}}}\n", "g.yaml")
        assert err.value.diagnostics[0].code == "RAC081"


def test_properties_csv() -> None:
    samples = parse_properties("time,node,cpu,mem\n0,/a,1.5,100\n1,a,2.5,\n", "p.csv")
    stats = {(s.node, s.prop): s for s in property_stats(samples)}
    assert stats["a", "cpu"].mean == 2.0 and stats["a", "cpu"].maximum == 2.5
    assert stats["a", "mem"].samples == 1
    assert stats["a", "cpu"].limit(3) == pytest.approx(2.0 + 3 * 0.5)
    for bad in (
        "node,cpu\n",
        "time,node,cpu,mem\n0,a,x,1\n",
        "time,node,cpu,mem\n0,a,1\n",
        "time,node,cpu,mem\n0,a,-1,1\n",
    ):
        with pytest.raises(RacError) as err:
            parse_properties(bad, "p.csv")
        assert err.value.diagnostics[0].code == "RAC082"


@pytest.mark.parametrize("ending", ["\r\n", "\r"], ids=["crlf", "cr"])
def test_properties_csv_line_endings(ending: str) -> None:
    """learn and replay read a CSV with CR LF or CR-only lines as the LF one (CR-only was
    "new-line character seen in unquoted field": RAC082 at line 0 in learn, exit 70 in
    replay)."""
    from rac.replay.sources import parse_samples

    text = "time,node,cpu,mem\n0,/a,1.5,100\n1,a,2.5,\n2,b,,7\n"
    other = text.replace("\n", ending)
    assert parse_properties(other, "p.csv") == parse_properties(text, "p.csv")
    assert parse_samples(other, "p.csv") == parse_samples(text, "p.csv")


def test_properties_csv_that_csv_cannot_read_is_located() -> None:
    """A field beyond csv's size limit, a quote left open: RAC082 at the line where csv
    stopped (learn said line 0; replay exited 70)."""
    from rac.replay.sources import parse_samples

    huge = "time,node,cpu,mem\n0,a,1,1\n1," + "x" * 200_000 + ",1,1\n"
    for parse in (parse_properties, parse_samples):
        with pytest.raises(RacError) as err:
            parse(huge, "p.csv")
        assert err.value.diagnostics[0].code == "RAC082"
        assert err.value.diagnostics[0].message.startswith("p.csv:3: not CSV: field larger")
    quoted = 'time,node,cpu,mem\n0,a,1,1\n1,"b,1,1\n2,c,1,1\n'
    for parse in (parse_properties, parse_samples):
        with pytest.raises(RacError) as err:
            parse(quoted, "p.csv")
        assert err.value.diagnostics[0].message.startswith("p.csv:3: ")
