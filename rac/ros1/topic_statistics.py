"""The observer host's use of ROS 1 topic statistics (``/statistics``): the rule is
:mod:`rac.runtime.topic_statistics`'s; this file subscribes ``/statistics``, judges each
report's connection as every connection of the host is judged (its ``callerid`` held
against the master), and subscribes or unsubscribes the topics themselves as the rule
asks, on a thread of its own (a subscription is a call to the master, which must not hold
up the sample loop).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from rac.runtime.topic_statistics import (
    STATISTICS_TOPIC,
    Eligible,
    Report,
    StatisticsFeed,
    refusal,
)

if TYPE_CHECKING:
    from rac.ros1.observe import Connections
    from rac.runtime.host import ObserverHost
    from rac.runtime.procs import ProcessProbe

AUTO, OFF = "auto", "off"
MODES = (AUTO, OFF)
QUEUE_SIZE = 1000  # reports waiting for the callback: a hundred topics report each second


def statistics_on(rospy: Any, mode: str) -> tuple[bool, str]:
    """Whether the host takes topics from ``/statistics`` (``mode`` ``auto``: when the
    robot has ``/enable_statistics`` on now, at the host's start), and why, for the log."""
    if mode == OFF:
        return False, "off (--statistics off)"
    try:
        enabled = bool(rospy.get_param("/enable_statistics", False))
    except Exception as err:  # the parameter server did not answer: the topics themselves
        return False, f"off (the parameter server did not answer: {err})"
    if not enabled:
        return False, "off (the robot's /enable_statistics is not true)"
    return True, "on (the robot's /enable_statistics is true)"


def report_of(msg: Any) -> Report:
    """A ``rosgraph_msgs/TopicStatistics`` as a :class:`Report`."""
    return Report(
        str(msg.topic),
        str(msg.node_pub),
        str(msg.node_sub),
        msg.window_start.to_sec(),
        msg.window_stop.to_sec(),
        int(msg.delivered_msgs),
        int(msg.dropped_msgs),
    )


class Subscriptions:
    """The host's own subscriptions of the eligible topics, made and ended on a thread of
    their own in the order asked.  ``subscribe(topic)`` returns the rospy subscriber."""

    def __init__(
        self,
        subscribe: Callable[[str], Any],
        on_error: Callable[[str], None],
    ) -> None:
        self.subscribe, self.on_error = subscribe, on_error
        self.subscribers: dict[str, Any] = {}
        self._asked: queue.Queue[tuple[bool, str]] = queue.Queue()
        self._thread = threading.Thread(target=self._run, name="racc-subscribe", daemon=True)
        self._thread.start()

    def ask(self, topic: str, subscribe: bool) -> None:
        self._asked.put((subscribe, topic))

    def _run(self) -> None:
        while True:
            subscribe, topic = self._asked.get()
            try:
                if subscribe and topic not in self.subscribers:
                    self.subscribers[topic] = self.subscribe(topic)
                elif not subscribe and topic in self.subscribers:
                    self.subscribers.pop(topic).unregister()
            except Exception as err:  # the master did not answer: the log says so
                self.on_error(f"{'subscribing' if subscribe else 'unsubscribing'} {topic}: {err}")


class StatisticsReceiver:
    """``/statistics`` into a :class:`StatisticsFeed`, and the feed's requests carried out."""

    def __init__(
        self,
        host: ObserverHost,
        eligible: dict[str, Eligible],
        connections: Connections,
        refuse: Callable[[str, str, str], None],
        subscribe: Callable[[str], Any],
        log: Callable[[int, str], None],
    ) -> None:
        self.host, self.connections, self.refuse, self.log = host, connections, refuse, log
        self.feed = StatisticsFeed(eligible, host.clock(), host.wall)
        self.subscriptions = Subscriptions(subscribe, lambda e: log(1, f"racc observe: {e}"))
        host.statistics_topics = self.feed.from_statistics
        self.impl: Any = None  # the /statistics subscription's rospy impl (its connections)

    def listen(self, rospy: Any) -> None:
        """Subscribe ``/statistics``."""
        from rosgraph_msgs.msg import TopicStatistics

        sub = rospy.Subscriber(
            STATISTICS_TOPIC, TopicStatistics, self.on_report, queue_size=QUEUE_SIZE
        )
        self.impl = sub.impl

    def on_report(self, msg: Any) -> None:
        """One ``rosgraph_msgs/TopicStatistics``, with its ``_connection_header``."""
        header = getattr(msg, "_connection_header", None)
        eligible = self.feed.eligible(str(msg.topic))
        if eligible is None:
            return  # a topic the host does not take from reports: nothing to judge
        if not self.connections.admits(STATISTICS_TOPIC, header, self.impl, True):
            return  # a forged callerid (refused and reported there)
        callerid = str(header.get("callerid", "")) if isinstance(header, dict) else ""
        report = report_of(msg)
        why = refusal(report, callerid, eligible)
        if why is not None:
            self.refuse(callerid, STATISTICS_TOPIC, why)
            return
        self.feed.report(self.host.clock(), report)

    def each_tick(self, probe: ProcessProbe) -> None:
        """The sample loop's turn: sources seen not running, reported messages due, and
        the subscriptions to make or end."""
        feed, host = self.feed, self.host
        now = host.clock()
        for node in feed.sources():
            feed.node_running(node, probe.running(node), now)
        step = feed.tick(now)
        for topic in step.retime:
            host.retime(topic)
        for topic, count in step.feed:
            host.messages(topic, count, reported=True)
        for topic in step.subscribe:
            self.subscriptions.ask(topic, True)
        for topic in step.unsubscribe:
            self.subscriptions.ask(topic, False)
        for line in step.lines:
            self.log(0, line)
