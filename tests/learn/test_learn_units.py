"""Unit tests of the learning steps: trends, Table 9.1, matching, rates, inputs."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from rac.errors import RacError
from rac.learn.correlate import TABLE, interpolate, pair_matches
from rac.learn.frequency import rate_stats
from rac.learn.graph import parse_graph
from rac.learn.properties import parse_properties, property_stats
from rac.learn.recording import Run, TopicData, merge_runs
from rac.learn.trends import CONSTANT, DECREASING, INCREASING, Signal, TopicTrends, topic_trends

D, C, UP = DECREASING, CONSTANT, INCREASING


def _topic(name: str, times: np.ndarray, **fields: np.ndarray) -> TopicData:
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
    )


def test_trends_of_a_rise_a_plateau_and_a_fall() -> None:
    t = np.arange(0.0, 30.0, 0.1)
    # Up for 10 s, flat for 10 s, down for 10 s: with b± the medians of the slopes.
    # Rates of different sizes, so the medians b± split the rising and falling slopes.
    speed = 1 + 0.5 * np.sin(t)
    rate = np.where(t < 10, speed, np.where(t < 20, 0.0, -speed))
    v = np.cumsum(rate) * 0.1
    trends = topic_trends(_topic("/x", t, v=v), occurrences=10, integrate=False)
    assert trends is not None
    codes = trends.codes[0]
    assert np.mean(codes[10:90] != D) > 0.95
    assert np.mean(codes[110:190] == C) > 0.9
    assert np.mean(codes[210:290] != UP) > 0.95


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


def _trends(name: str, times: np.ndarray, codes: list[list[int]]) -> TopicTrends:
    signals = tuple(Signal(name, f"f{i}", False) for i in range(len(codes)))
    return TopicTrends(name, times, signals, np.array(codes, dtype=np.int8), 1.0)


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


def test_pair_matches_counts_both_directions() -> None:
    rng = np.random.default_rng(1)
    ta, tb = np.sort(rng.uniform(0, 10, 50)), np.sort(rng.uniform(0, 10, 70))
    a = _trends("/a", ta, rng.integers(0, 3, (3, 50)).tolist())
    b = _trends("/b", tb, rng.integers(0, 3, (2, 70)).tolist())
    m, checks = pair_matches(a, b)
    b_at_a, na = interpolate(ta, b)
    a_at_b, nb = interpolate(tb, a)
    expected = (a.codes[:, None, :] == b_at_a[None, :, :]).sum(axis=2)
    expected += (a_at_b[:, None, :] == b.codes[None, :, :]).sum(axis=2)
    assert checks == na + nb
    assert m.tolist() == expected.tolist()


def test_regularity_is_mean_over_sigma_above_alpha() -> None:
    rng = np.random.default_rng(2)
    steady = np.arange(0, 100, 0.1) + rng.normal(0, 0.002, 1000)
    bursty = np.cumsum(rng.exponential(0.1, 1000))
    for alpha, regular in ((10, True), (0.5, True)):
        stats = rate_stats(_topic("/s", steady), alpha)
        assert stats is not None and stats.regular is regular
        assert stats.rate_hz == pytest.approx(10, rel=0.01)
        assert 0 < stats.tolerance_hz < 1
    assert not rate_stats(_topic("/b", bursty), 2.5).regular  # type: ignore[union-attr]
    assert rate_stats(_topic("/b", bursty), 0.5).regular  # type: ignore[union-attr]
    assert rate_stats(_topic("/few", np.array([0.0, 1.0])), 2.5) is None


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
