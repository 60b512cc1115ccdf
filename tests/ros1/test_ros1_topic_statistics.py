"""``/statistics`` reports into the observer host (rac/ros1/topic_statistics.py), with the
connection judge of rac/ros1/observe.py and a fake master: a report counts only on a
connection whose callerid the master vouches for, from the subscriber it is about; a
forged or a stranger's report is refused once and feeds nothing.  No ROS needed."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rac.logic import Atom
from rac.passes.observers import ObserverSpec, TopicSource
from rac.ros1.observe import Connections
from rac.ros1.topic_statistics import OFF, StatisticsReceiver, report_of, statistics_on
from rac.runtime.host import ObserverHost
from rac.runtime.sources import SourceCheck
from rac.runtime.topic_statistics import eligible_topics

GOBS = ObserverSpec(
    "GObs",
    "imu_1_gobs",
    (("topic", "/imu_1"), ("delta", 0.02), ("dev", 0.0022)),
    (Atom("ok", ("imu_1",)),),
)
SOURCES = {"/imu_1": TopicSource("/imu_1", "sensor_msgs/Imu", ("imu_relay_1",), ("imu_relay_2",))}
MASTER = {"/imu_relay_2": "http://h:2/", "/racc_test_forger": "http://h:9/"}


@dataclass
class Stamp:
    secs: float

    def to_sec(self) -> float:
        return self.secs


@dataclass
class Conn:
    header: dict[str, str]
    endpoint_id: str


@dataclass
class Impl:
    connections: list[Conn] = field(default_factory=list)
    removed: list[Conn] = field(default_factory=list)

    def remove_connection(self, c: Conn) -> None:
        self.removed.append(c)
        self.connections.remove(c)


@dataclass
class Msg:
    """A rosgraph_msgs/TopicStatistics as rospy hands it over."""

    _connection_header: dict[str, str]
    topic: str = "/imu_1"
    node_pub: str = "/imu_relay_1"
    node_sub: str = "/imu_relay_2"
    window_start: Stamp = field(default_factory=lambda: Stamp(10.0))
    window_stop: Stamp = field(default_factory=lambda: Stamp(11.0))
    delivered_msgs: int = 50
    dropped_msgs: int = 0


class FakeRospy:
    def __init__(self, params: dict[str, Any] | Exception) -> None:
        self.params = params

    def get_param(self, name: str, default: Any) -> Any:
        if isinstance(self.params, Exception):
            raise self.params
        return self.params.get(name, default)


def receiver(
    clock: list[float] | None = None,
) -> tuple[StatisticsReceiver, Impl, list[tuple[str, str, str]], ObserverHost]:
    now = clock if clock is not None else [0.0]
    host = ObserverHost([GOBS], sources=SOURCES, clock=lambda: now[0])
    refused: list[tuple[str, str, str]] = []

    def refuse(*r: str) -> None:
        refused.append(r)  # type: ignore[arg-type]

    connections = Connections(SourceCheck(SOURCES), refuse, MASTER.get)
    eligible = eligible_topics(host.bank, SOURCES)
    reports = StatisticsReceiver(host, eligible, connections, refuse, lambda t: None, print)
    impl = Impl()
    reports.impl = impl
    return reports, impl, refused, host


def connect(impl: Impl, callerid: str, uri: str) -> dict[str, str]:
    header = {"callerid": callerid, "type": "rosgraph_msgs/TopicStatistics"}
    impl.connections.append(Conn(header, uri))
    return header


def windows(header: dict[str, str], n: int, **changes: Any) -> list[Msg]:
    return [
        Msg(header, window_start=Stamp(10.0 + k), window_stop=Stamp(11.0 + k), **changes)
        for k in range(n)
    ]


def test_the_robots_parameter_and_the_operators_switch_say_whether() -> None:
    assert statistics_on(FakeRospy({"/enable_statistics": True}), "auto")[0]
    assert not statistics_on(FakeRospy({}), "auto")[0]
    assert statistics_on(FakeRospy({"/enable_statistics": True}), OFF) == (
        False,
        "off (--statistics off)",
    )
    assert not statistics_on(FakeRospy(OSError("no master")), "auto")[0]


def test_a_report_is_read_as_it_came() -> None:
    report = report_of(Msg({}, delivered_msgs=7, dropped_msgs=2))
    assert (report.topic, report.node_pub, report.node_sub) == (
        "/imu_1",
        "/imu_relay_1",
        "/imu_relay_2",
    )
    assert (report.span, report.delivered, report.dropped) == (1.0, 7, 2)


def test_the_subscribers_own_reports_are_taken() -> None:
    reports, impl, refused, _ = receiver()
    header = connect(impl, "/imu_relay_2", "http://h:2/")
    for msg in windows(header, 3):
        reports.on_report(msg)
    assert refused == [] and reports.feed.source("/imu_1") == "imu_relay_2"


def test_a_report_in_the_subscribers_name_from_another_node_is_refused_once() -> None:
    reports, impl, refused, _ = receiver()
    header = connect(impl, "/racc_test_forger", "http://h:9/")
    for msg in windows(header, 5, delivered_msgs=5000):
        reports.on_report(msg)
    assert reports.feed.source("/imu_1") is None
    assert {r[0] for r in refused} == {"/racc_test_forger"}
    assert "in the name of imu_relay_2" in refused[0][2]
    assert impl.removed == []  # its connection is no forgery: its reports count for nothing


def test_a_forged_callerid_is_refused_and_its_connection_closed() -> None:
    reports, impl, refused, _ = receiver()
    # registered with the master at :9, its connection says it is /imu_relay_2 (at :2)
    header = connect(impl, "/imu_relay_2", "http://h:9/")
    for msg in windows(header, 5, delivered_msgs=5000):
        reports.on_report(msg)
    assert reports.feed.source("/imu_1") is None
    assert len(impl.removed) == 1 and "a forged callerid" in refused[0][2]


def test_a_report_of_a_topic_not_taken_from_reports_is_left_unjudged() -> None:
    reports, impl, refused, _ = receiver()
    header = connect(impl, "/racc_test_forger", "http://h:9/")
    reports.on_report(Msg(header, topic="/rosout"))
    assert refused == [] and reports.feed.source("/imu_1") is None


def test_each_tick_feeds_the_host_and_asks_for_the_subscriptions() -> None:
    clock = [0.0]
    reports, impl, _, host = receiver(clock)
    asked: list[tuple[str, bool]] = []
    reports.subscriptions.ask = lambda topic, subscribe: asked.append((topic, subscribe))  # type: ignore[method-assign]

    class Probe:
        def running(self, node: str) -> bool | None:
            return True

    header = connect(impl, "/imu_relay_2", "http://h:2/")
    first, second = windows(header, 2)
    reports.on_report(first)  # a connection's first window: its timing alone
    clock[0] = 1.0
    reports.on_report(second)  # fed over its window, a window and the lag later
    reports.each_tick(Probe())  # type: ignore[arg-type]
    assert host.reported == 0 and asked == []
    clock[0] = 2.5
    reports.each_tick(Probe())  # type: ignore[arg-type]
    assert 0 < host.reported < 50 and host.received == 0
    clock[0] = 3.0  # its next report is overdue: the topic is received
    reports.each_tick(Probe())  # type: ignore[arg-type]
    assert asked == [("/imu_1", True)]
    clock[0] = 10.0
    reports.each_tick(Probe())  # type: ignore[arg-type]
    assert host.reported == 50  # what was reported is fed until the topic's own come
    assert host.statistics_topics is not None and host.statistics_topics() == 0
