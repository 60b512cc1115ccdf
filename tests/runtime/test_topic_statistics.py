"""A topic's cadence from its subscribers' topic statistics (rac.runtime.topic_statistics):
which reports count, how a report becomes messages, one source at a time, and the host's
own subscription when no source can be trusted.  The frequency observer's verdicts are
those of a real ObserverHost fed as rac.ros1.topic_statistics feeds it, from reports made
as roscpp makes them (a report when a message arrives more than 1 s after the last one)."""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from rac.logic import Atom
from rac.observe import ObserverBank
from rac.passes.observers import ObserverSpec, TopicSource
from rac.runtime.host import ObserverHost
from rac.runtime.topic_statistics import (
    DIRECT,
    REPORTED,
    RETURN_REPORTS,
    START_S,
    WAITING,
    Eligible,
    Pacer,
    Report,
    StatisticsFeed,
    eligible_topics,
    refusal,
)

RATE = 100.0


def gobs(topic: str, rate: float = RATE) -> ObserverSpec:
    """A frequency observer as the compiler writes one for ``@ RATE Hz`` (±10 %)."""
    name = topic.strip("/")
    return ObserverSpec(
        "GObs",
        f"{name}_gobs",
        (("topic", topic), ("delta", 1 / rate), ("dev", 1 / (0.9 * rate) - 1 / rate)),
        (Atom("ok", (name,)),),
    )


TOPIC = Eligible("/t", frozenset({"sub", "other_sub"}), frozenset({"pub"}), 2.5)


# -- which reports count ----------------------------------------------------------------


def report(**changes: object) -> Report:
    fields: dict[str, object] = dict(
        topic="/t",
        node_pub="/pub",
        node_sub="/sub",
        window_start=10.0,
        window_stop=11.0,
        delivered=100,
    )
    fields.update(changes)
    return Report(**fields)  # type: ignore[arg-type]


def test_a_report_counts_from_a_model_subscriber_about_a_model_publisher() -> None:
    assert refusal(report(), "/sub", TOPIC) is None
    assert refusal(report(node_sub="other_sub"), "/other_sub", TOPIC) is None


def test_a_report_in_another_nodes_name_is_refused() -> None:
    why = refusal(report(), "/stranger", TOPIC)
    assert why == (
        "a report of /t in the name of sub (a report counts only from the subscriber it is about)"
    )


def test_a_report_of_a_node_the_model_does_not_have_subscribe_is_refused() -> None:
    why = refusal(report(node_sub="/rostopic_123"), "/rostopic_123", TOPIC)
    assert why == "not a subscriber of /t in the model (that is other_sub, sub)"


def test_a_report_about_a_publisher_the_model_does_not_have_is_refused() -> None:
    why = refusal(report(node_pub="/intruder"), "/sub", TOPIC)
    assert why == "a report of /t from intruder, not a publisher of it in the model (that is pub)"
    anyone = Eligible("/t", frozenset({"sub"}), frozenset(), 2.5)  # the model names none
    assert refusal(report(node_pub="/intruder"), "/sub", anyone) is None


def test_a_report_that_counts_nothing_sensible_is_refused() -> None:
    assert "not one" in str(refusal(report(delivered=-1), "/sub", TOPIC))
    assert "not one" in str(refusal(report(window_stop=10.0), "/sub", TOPIC))


# -- which topics -------------------------------------------------------------------------


def test_only_topics_timed_alone_and_subscribed_in_the_model_are_eligible() -> None:
    biq = ObserverSpec(
        "BiQObs",
        "pose_scan",
        (("topic1", "/pose"), ("field1", "x"), ("topic2", "/scan"), ("field2", "y")),
        (Atom("ok", ("pose_scan",)),),
    )
    bank = ObserverBank([gobs("/a"), gobs("/b", 1.0), gobs("/pose"), gobs("/c"), biq])
    sources = {
        "/a": TopicSource("/a", None, ("pub",), ("sub",)),
        "/b": TopicSource("/b", None, ("pub",), ("/sub",)),
        "/pose": TopicSource("/pose", None, ("pub",), ("sub",)),  # a field is read
        "/c": TopicSource("/c", None, ("pub",), ()),  # nothing of the model subscribes it
    }
    found = eligible_topics(bank, sources)
    assert sorted(found) == ["/a", "/b"]
    assert found["/a"] == Eligible("/a", frozenset({"sub"}), frozenset({"pub"}), 2.5)
    assert found["/b"].max_window_s == 2.5  # 2.5 periods of 1 s
    assert eligible_topics(bank, None) == {}  # an older racc's observers.yaml


# -- report to messages -------------------------------------------------------------------


def test_the_pacer_spreads_a_reports_messages_evenly_and_cancels_the_rest() -> None:
    pacer = Pacer()
    pacer.add("/t", 10.0, 11.0, 100)
    assert pacer.take(9.9) == []
    assert pacer.take(10.5) == [("/t", 50)]
    assert pacer.take(10.75) == [("/t", 25)]
    assert pacer.cancel("/t") == 25
    assert pacer.take(12.0) == []
    pacer.add("/t", 10.0, 11.0, 10)
    assert pacer.take(20.0) == [("/t", 10)]  # late: all at once
    assert not pacer.pending("/t")


# -- the feed, driven as the host's transport drives it ------------------------------------


@dataclass
class Robot:
    """One topic published at ``rate(t)`` Hz (0: silent), received by subscriber ``sub``
    whose roscpp reports a window when a message comes more than 1 s after the last
    report, ``transit`` s later at the host; ``clump``: messages arrive in clumps."""

    rate: Callable[[float], float] = lambda t: RATE
    until: float = 40.0
    clump: float = 0.0
    transit: float = 0.003
    arrivals: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        t = 0.5
        while t < self.until:
            r = self.rate(t)
            t += 1.0 / r if r > 0 else 0.01
            if r > 0:
                self.arrivals.append(math.ceil(t / self.clump) * self.clump if self.clump else t)

    def reports(self, sub: str = "sub", start: float = 0.0) -> list[tuple[float, Report]]:
        """(host time it arrives, report) of subscriber ``sub`` connected at ``start``."""
        out, last, count = [], None, 0
        for m in (a for a in self.arrivals if a >= start):
            if last is None:
                last = m  # a connection's first window starts with its first message
            count += 1
            if last + 1.0 < m:
                out.append((m + self.transit, Report("/t", "pub", sub, last, m, count)))
                last, count = m, 0
        return out


@dataclass
class Run:
    feed: StatisticsFeed
    verdicts: list[tuple[float, str]]
    subscribed: list[float]
    unsubscribed: list[float]


def drive(
    robot: Robot,
    reports: list[tuple[float, Report]],
    *,
    down: tuple[str, float, float] | None = None,
    connect_s: float = 0.2,
    until: float | None = None,
) -> Run:
    """The host fed from ``reports`` as the transport feeds it: each report when it
    arrives, the feed's tick every 0.05 s (the lean receiver's pass) and what it asks (the
    host's own subscription delivers the robot's messages ``connect_s`` after it is asked,
    in 0.05 s batches); ``down``: (node, from, to) that node does not run."""
    now = [0.0]
    host = ObserverHost([gobs("/t")], clock=lambda: now[0])
    feed = StatisticsFeed({"/t": TOPIC}, 0.0)
    pending = sorted(reports, key=lambda r: r[0])
    verdicts: list[tuple[float, str]] = []
    subscribed: list[float] = []
    unsubscribed: list[float] = []
    receiving_from: float | None = None
    tick, end = 0.0, until or robot.until
    while tick < end:
        while pending and pending[0][0] <= tick:
            at, rep = pending.pop(0)
            now[0] = at
            feed.report(at, rep)
        now[0] = tick
        if receiving_from is not None and tick >= receiving_from:
            batch = [a for a in robot.arrivals if tick - 0.05 <= a < tick]
            if batch and feed.direct("/t", tick):
                host.messages("/t", len(batch))
        if down is not None:
            node, since, to = down
            feed.node_running(node, not since <= tick < to, tick)
        step = feed.tick(tick)
        for topic in step.retime:
            host.retime(topic)
        for topic, n in step.feed:
            host.messages(topic, n, reported=True)
        if step.subscribe:
            subscribed.append(tick)
            receiving_from = tick + connect_s
        if step.unsubscribe:
            unsubscribed.append(tick)
            receiving_from = None
        host.advance()
        verdicts += [(round(v.t, 2), str(v)) for v in host.take_changes()]
        tick = round(tick + 0.05, 6)
    return Run(feed, verdicts, subscribed, unsubscribed)


def negatives(run: Run) -> list[float]:
    return [t for t, v in run.verdicts if v.startswith("not_")]


@pytest.mark.parametrize("clump", [0.0, 0.2, 1 / 3])
def test_a_healthy_topic_is_ok_from_its_reports_alone(clump: float) -> None:
    robot = Robot(clump=clump)
    run = drive(robot, robot.reports())
    assert run.verdicts[:1] and run.verdicts[0][1] == "ok(t)"
    assert negatives(run) == [] and run.subscribed == []
    assert run.feed.mode("/t") == REPORTED and run.feed.from_statistics() == 1
    # Every message the subscriber reported (but its first window's) is fed, none twice:
    # by the end, all those of the reports that came 2.5 s before (a window and the lag).
    reports = robot.reports()[1:]
    done = sum(r.delivered for at, r in reports if at < robot.until - 2.5)
    assert done <= run.feed.reported <= sum(r.delivered for _, r in reports)


@pytest.mark.parametrize("seed", range(8))
def test_a_topic_in_clumps_of_varying_lateness_is_ok_from_its_reports(seed: int) -> None:
    """The PR2 recording's joint states come in clumps 1/3 s apart, each up to 0.1 s late:
    a subscriber's windows then last 1.0-1.4 s, and the feeding delay must not follow
    them (a window stretched by 0.4 s reads as a topic 30 % slow)."""
    rng = random.Random(seed)
    robot = Robot(until=60.0, clump=1 / 3)
    late: dict[float, float] = {}
    robot.arrivals = sorted(
        a + late.setdefault(round(a, 4), rng.uniform(0.0, 0.1)) for a in robot.arrivals
    )
    spans = [r.span for _, r in robot.reports()]
    assert min(spans) < 1.05 and max(spans) > 1.3
    run = drive(robot, robot.reports())
    assert negatives(run) == [] and run.subscribed == [], run.verdicts


def test_a_slower_topic_is_not_ok_and_one_within_its_band_is() -> None:
    slow = Robot(rate=lambda t: RATE if t < 15 else 0.85 * RATE)
    found = negatives(drive(slow, slow.reports()))
    assert found and 15 < found[0] < 20
    within = Robot(rate=lambda t: RATE if t < 15 else 0.92 * RATE)
    assert negatives(drive(within, within.reports())) == []


def test_a_topic_that_stops_is_not_ok_then_ok_when_it_runs_again() -> None:
    robot = Robot(rate=lambda t: 0.0 if 20 <= t < 26 else RATE)
    run = drive(robot, robot.reports())
    found = negatives(run)
    # The last report covers up to a window before the stop and is fed a window and
    # PACE_LAG_S late: the stop is seen 2-3.5 s after it (received, 1.05 s).
    assert len(found) == 1 and 21.5 < found[0] < 23.5, run.verdicts
    assert run.subscribed and 20.5 < run.subscribed[0] < 22.0  # its reports stopped
    assert run.verdicts[-1][1] == "ok(t)"
    assert run.feed.mode("/t") == REPORTED  # its reports came back


@pytest.mark.parametrize("connect_s", [0.05, 0.3, 0.8])
def test_a_reporter_that_dies_is_no_silent_topic(connect_s: float) -> None:
    """The subscriber's process ends at 20 s: its reports stop with it, the host receives
    the topic itself, and the topic (which runs) is never judged wrong."""
    robot = Robot()
    reports = [r for r in robot.reports() if r[0] < 20.0]
    run = drive(robot, reports, down=("sub", 20.1, 99.0), connect_s=connect_s)
    assert negatives(run) == [], run.verdicts
    assert run.subscribed == [pytest.approx(20.1)]
    assert run.feed.mode("/t") == DIRECT and run.feed.from_statistics() == 0


def test_a_reporter_that_stops_reporting_while_running_is_no_silent_topic() -> None:
    robot = Robot(clump=1 / 3)
    reports = [r for r in robot.reports() if r[0] < 20.0]
    run = drive(robot, reports, connect_s=0.3)
    assert negatives(run) == [], run.verdicts
    assert len(run.subscribed) == 1 and 20.0 < run.subscribed[0] < 21.5


def test_a_reporter_back_is_used_again_once_it_reports_in_a_row() -> None:
    """Killed at 20 s and restarted at 30 s: its first window starts with its first message
    (not fed), then RETURN_REPORTS on time, then the host's subscription ends."""
    for clump in (0.0, 1 / 3):
        robot = Robot(until=50.0, clump=clump)
        reports = [r for r in robot.reports() if r[0] < 20.0]
        reports += robot.reports(start=30.0)
        run = drive(robot, reports, down=("sub", 20.1, 30.0))
        assert negatives(run) == [], (clump, run.verdicts)
        assert len(run.unsubscribed) == 1
        assert 30.0 + RETURN_REPORTS < run.unsubscribed[0] < 30.0 + RETURN_REPORTS + 3.5
        assert run.feed.mode("/t") == REPORTED


def test_a_topic_no_trusted_subscriber_reports_is_received() -> None:
    run = drive(Robot(until=10.0), [])
    assert run.subscribed == [pytest.approx(START_S)]
    assert run.feed.mode("/t") == DIRECT and negatives(run) == []
    assert any(v == "ok(t)" for _, v in run.verdicts)


def test_reports_of_windows_too_long_to_time_by_are_left_for_the_topic_itself() -> None:
    feed = StatisticsFeed({"/t": TOPIC}, 0.0)
    feed.report(4.0, report(window_start=0.0, window_stop=4.0, delivered=40))
    step = feed.tick(4.1)
    assert feed.mode("/t") == DIRECT and step.subscribe == ("/t",)
    assert "too far apart" in step.lines[0]


def test_one_source_at_a_time() -> None:
    """Two subscribers report the same messages: only the first one's are fed."""
    robot = Robot(until=20.0)
    both = robot.reports("sub") + robot.reports("other_sub")
    run = drive(robot, both)
    assert run.feed.source("/t") == "sub"
    fed = sum(r.delivered for _, r in robot.reports("sub")[1:])
    assert run.feed.reported <= fed
    assert negatives(run) == []


def test_a_report_before_any_tick_waits_and_the_host_counts_it_apart() -> None:
    feed = StatisticsFeed({"/t": TOPIC}, 0.0)
    assert feed.mode("/t") == WAITING and feed.mode("/other") is None
    assert feed.direct("/other", 0.0)  # not an eligible topic: the host's own, as before
    assert not feed.direct("/t", 0.0)  # not subscribed: a stray message does not count
    host = ObserverHost([gobs("/t")], clock=lambda: 1.0)
    host.messages("/t", 5, reported=True)
    host.messages("/t", 2)
    assert (host.reported, host.received) == (5, 2)


def test_retiming_a_topic_starts_its_frequency_observers_afresh_and_keeps_their_verdict() -> None:
    now = [0.0]
    host = ObserverHost([gobs("/t")], clock=lambda: now[0])
    for k in range(400):  # 4 s at 100 Hz: ok
        now[0] = k / RATE
        host.messages("/t", 1)
    host.advance()
    assert [str(v) for v in host.current.values()] == ["ok(t)"]
    before = host.bank.observers[0]
    host.retime("/t")
    assert host.bank.observers[0] is not before
    assert [str(v) for v in host.current.values()] == ["ok(t)"]  # stands until it speaks
    assert host.bank.retime("/other") == 0


def test_the_subscribers_of_a_topic_are_written_and_read_back(tmp_path: Path) -> None:
    from rac.load.files import load_observer_file
    from rac.targets.observers_yaml import _sources

    sources = (TopicSource("/t", "std_msgs/Int32", ("pub",), ("a", "b")),)
    path = tmp_path / "observers.yaml"
    path.write_text("robot: r\nobservers: []\n" + _sources(sources), encoding="utf-8")
    loaded = load_observer_file(str(path)).sources
    assert loaded == {"/t": sources[0]}
