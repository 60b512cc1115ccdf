"""A topic's cadence from its subscribers' topic statistics instead of its messages.

With ``/enable_statistics`` on, every roscpp and rospy subscriber of a ROS 1 robot publishes
on ``/statistics``, per connection (one publisher of the topic) and window, how many
messages it received (``rosgraph_msgs/TopicStatistics``).  For a topic watched only for
its rate and liveness (no observer reads a field of it), that is what the frequency
observer needs, and the observer host then has no reason to receive the topic itself: a
subscriber the model already has does.  This module is the rule; ``rac.ros1.observe``
carries it out.

**Which reports count** (:func:`refusal`).  A report is a subscriber's word about another
node's messages, so it counts only when its connection's ``callerid`` (verified against the
master, as every ROS 1 connection of the host is) is the report's ``node_sub``, that node
subscribes the topic in the model, and ``node_pub`` publishes it there.  Anything else is
refused and reported once (docs/security.md).

**Report to messages** (:class:`Pacer`).  A report comes when the subscriber receives the
first message more than a window (1 s with ``/statistics_window_max_size`` 1) after its
last report; it covers the messages received since (``window_start`` to ``window_stop``,
the message that closed it included; the next window starts there).  The first window of a
connection starts with its first message instead, and counts it, so that its count does
not fit its length (by a message, or by a whole clump of a topic that comes in clumps): a
report counts only when its window continues the last one of its connection.  Its
``delivered_msgs`` is every message that
arrived: roscpp counts a message its own queue dropped after arrival in both
``delivered_msgs`` and ``dropped_msgs``, rospy counts gaps in ``header.seq`` in the latter,
so only ``delivered_msgs`` counts messages, and it alone is fed.  The host feeds a report's
messages spread evenly over its window's length, each the same time D after it would have
come (the report came at the window's end), from where the last report's ended: D is the
longest window of the source and :data:`PACE_LAG_S`, and grows slowly when a longer window
comes (a moving D would stretch or squeeze a window, which the frequency observer would read
as a slower or a faster topic).  The frequency observer then sees the topic at the rate the
subscriber saw, as a steady stream D late, rather than a clump a second (a silence of a
second, every second).  It has no header stamps nor sequence numbers of these messages: it
times them by their (paced) arrival.  The lag is what lets the host take over a topic whose
source stopped before the reported messages run out (see below); what it costs is that a
topic that stops is seen so much later: its last report covers the messages up to a window
before the stop, fed up to D after it.

**One subscriber at a time, and the topic itself when none can be trusted**
(:class:`StatisticsFeed`).  Several subscribers report the same messages: a topic is taken
from one of them (its *source*).  A report comes only with a message, so a source that
stops reporting is either a topic that stopped or a subscriber that stopped, which the
reports cannot tell apart.  The host then receives the topic itself (the lean path of
``rac.ros1.tcpros``): if the topic runs, its messages come and nothing is judged wrong;
if it stopped, the topic is silent there too, and its observer says so.  That is done when
the source's report is :data:`OVERDUE_S` past its due time, or at once when the host sees
the source node not running; and at the start for a topic no trusted subscriber reported
within :data:`START_S`.  Once a trusted subscriber reports again, :data:`RETURN_REPORTS` in
a row on time, the topic is taken from it again and the host's own subscription ends.
Only one of the two feeds a topic at any time, and each until the other has begun: the
host's own messages count from the first that arrives (the reports' messages still waiting
are dropped then), the reports' from the first of them fed after the topic is taken from
statistics again (the host's own subscription ends then, and the topic's frequency
observers start afresh: a topic that comes in clumps, received, and its reports, fed
evenly, would make one window's mean of neither).  A gap between the two would be
messages missing from the frequency observer's window, which it would read as a slower
topic.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from rac.observe import ObserverBank
from rac.observe.gobs import GObs
from rac.passes.observers import TopicSource
from rac.runtime.sources import node_name

STATISTICS_TOPIC = "/statistics"
STATISTICS_TYPE = "rosgraph_msgs/TopicStatistics"
# A report's messages are fed this long, plus the longest of the source's recent windows,
# after they came: a source that stops is found (OVERDUE_S) and the topic is received
# before the last report's messages have all been fed.
PACE_LAG_S = 1.0
# A source's next report is overdue this long after the longest of its recent windows.
OVERDUE_S = 0.5
START_S = 3.5  # at the start, how long a topic waits for a trusted report (its second)
RETURN_REPORTS = 3  # reports in a row, on time, before a topic is taken from them again
# The longest window a report may cover (or MAX_WINDOW_PERIODS of the topic's period): a
# stop is seen that much later.  roscpp and rospy widen a window for a topic with fewer
# than 10 messages in one, up to /statistics_window_max_size (64 s by default).
MAX_WINDOW_S = 2.5
MAX_WINDOW_PERIODS = 2.5
RECENT_WINDOWS = 3  # a source's due time: the longest of its last windows
DELAY_GROWTH = 0.02  # the feeding delay grows by this share of a window at most
CONTINUES_S = 1e-3  # a window that starts this close to where the last one stopped continues it


@dataclass(frozen=True, slots=True)
class Report:
    """One ``rosgraph_msgs/TopicStatistics``: what ``node_sub`` received from ``node_pub``
    on ``topic`` in its window (times in seconds, on the reporting node's clock)."""

    topic: str
    node_pub: str
    node_sub: str
    window_start: float
    window_stop: float
    delivered: int
    dropped: int = 0

    @property
    def span(self) -> float:
        return self.window_stop - self.window_start


@dataclass(frozen=True, slots=True)
class Eligible:
    """A topic the host may take from statistics: its model's subscribers and publishers,
    and the longest window a report of it may cover."""

    topic: str
    subscribers: frozenset[str]
    publishers: frozenset[str]  # empty: the model names none, any counts
    max_window_s: float


def eligible_topics(
    bank: ObserverBank, sources: Mapping[str, TopicSource] | None
) -> dict[str, Eligible]:
    """The topics whose only observers are frequency observers (no field read) and which
    a node of the model subscribes."""
    kinds: dict[str, set[type]] = {}
    periods: dict[str, float] = {}
    for obs in bank.observers:
        for topic, _ in obs.needs.topics:
            kinds.setdefault(topic, set()).add(type(obs))
            if isinstance(obs, GObs):
                periods[topic] = min(periods.get(topic, math.inf), obs.delta)
    fields = bank.topic_fields()
    out = {}
    for topic, source in sorted((sources or {}).items()):
        if not source.subscribers or fields.get(topic) or kinds.get(topic) != {GObs}:
            continue
        out[topic] = Eligible(
            topic,
            frozenset(node_name(n) for n in source.subscribers),
            frozenset(node_name(n) for n in source.publishers),
            max(MAX_WINDOW_S, MAX_WINDOW_PERIODS * periods[topic]),
        )
    return out


def refusal(report: Report, callerid: str, topic: Eligible) -> str | None:
    """Why a report of an eligible topic, sent on a connection whose verified ``callerid``
    is given, does not count (None: it does).  The reasons name no numbers: a refusal is
    logged once per kind."""
    sender, sub, pub = node_name(callerid), node_name(report.node_sub), node_name(report.node_pub)
    if sender != sub:
        return (
            f"a report of {report.topic} in the name of {sub or 'nobody'} (a report counts "
            "only from the subscriber it is about)"
        )
    if sub not in topic.subscribers:
        shown = ", ".join(sorted(topic.subscribers))
        return f"not a subscriber of {report.topic} in the model (that is {shown})"
    if topic.publishers and pub not in topic.publishers:
        shown = ", ".join(sorted(topic.publishers))
        return (
            f"a report of {report.topic} from {pub or 'nobody'}, not a publisher of it in the "
            f"model (that is {shown})"
        )
    if report.delivered < 0 or not report.span > 0:
        return f"a report of {report.topic} whose window or count is not one"
    return None


@dataclass(slots=True)
class _Span:
    start: float
    end: float
    count: int
    fed: int = 0

    def due(self, now: float) -> int:
        """Messages of the span due by ``now`` and not fed yet: the i-th of n at
        start + (end - start)·i/n."""
        if now >= self.end:
            return self.count - self.fed
        if now <= self.start:
            return 0
        return int(self.count * (now - self.start) / (self.end - self.start)) - self.fed


class Pacer:
    """Each topic's reported messages, spread over time (module docstring)."""

    def __init__(self) -> None:
        self._spans: dict[str, list[_Span]] = {}

    def add(self, topic: str, start: float, end: float, count: int) -> None:
        """``count`` messages of ``topic`` to feed evenly from ``start`` to ``end``."""
        if count > 0:
            self._spans.setdefault(topic, []).append(_Span(start, max(end, start + 1e-6), count))

    def cancel(self, topic: str) -> int:
        """Drop the topic's messages not fed yet; how many."""
        return sum(s.count - s.fed for s in self._spans.pop(topic, []))

    def pending(self, topic: str) -> bool:
        return bool(self._spans.get(topic))

    def take(self, now: float) -> list[tuple[str, int]]:
        """(topic, messages due) of every topic with some due by ``now``."""
        out = []
        for topic, spans in list(self._spans.items()):
            due = 0
            for span in spans:
                n = span.due(now)
                span.fed += n
                due += n
            if due:
                out.append((topic, due))
            kept = [s for s in spans if s.fed < s.count]
            if kept:
                self._spans[topic] = kept
            else:
                del self._spans[topic]
        return out


WAITING, REPORTED, DIRECT = "waiting", "reported", "direct"


@dataclass(slots=True)
class _Heard:
    """What the host heard from one subscriber of a topic."""

    last: float = -math.inf  # host time of its last usable report
    windows: deque[float] = field(default_factory=lambda: deque(maxlen=RECENT_WINDOWS))
    streak: int = 0  # usable reports in a row, each on time
    longest: float = 0.0  # the longest window it ever reported: the feeding delay's part
    stops: dict[str, float] = field(default_factory=dict)  # publisher -> last window_stop

    @property
    def window(self) -> float:
        """The longest of its recent windows."""
        return max(self.windows, default=0.0)

    def due(self) -> float:
        """When its next report is overdue."""
        return self.last + self.window + OVERDUE_S


@dataclass(slots=True)
class _State:
    topic: Eligible
    mode: str = WAITING
    source: str | None = None  # the subscriber whose reports are fed
    heard: dict[str, _Heard] = field(default_factory=dict)
    # Publisher -> (window_stop, feeding end) of the last report of it that was fed: the
    # next one that continues its window is fed from where it ended.
    fed: dict[str, tuple[float, float]] = field(default_factory=dict)
    delay: float = 0.0  # how long after they came its reported messages are fed (0: unset)
    # Which messages count now: the host's own (it subscribed the topic), the reported
    # ones; both while one hands over to the other (module docstring).
    own: bool = False
    paced: bool = False
    asked: float = 0.0  # when the host's own subscription was asked for


@dataclass(frozen=True, slots=True)
class FeedStep:
    """What one tick of :class:`StatisticsFeed` asks of the transport."""

    feed: tuple[tuple[str, int], ...]  # (topic, messages) to hand the host now
    retime: tuple[str, ...]  # topics whose frequency observers start afresh first
    subscribe: tuple[str, ...]  # topics to receive directly from now on
    unsubscribe: tuple[str, ...]  # topics no longer to receive
    lines: tuple[str, ...]  # for the log


class StatisticsFeed:
    """Which eligible topic is fed from which subscriber's reports, or received directly
    (module docstring).  Thread-safe: reports come on the transport's callback thread, the
    host's own messages on its receiving thread, :meth:`tick` on the sample loop; every
    time is the host's clock."""

    def __init__(
        self,
        topics: Mapping[str, Eligible],
        start: float,
        wall: Callable[[float], float] = lambda t: t,
    ) -> None:
        self.start = start
        self.wall = wall  # the log's time of a time of the feed
        self._states = {t: _State(e) for t, e in topics.items()}
        self._pacer = Pacer()
        self._lock = threading.Lock()
        self._subscribe: list[str] = []
        self._unsubscribe: list[str] = []
        self._lines: list[str] = []
        self._down: set[str] = set()  # source nodes seen not running, until they are again
        self.reported = 0  # messages fed from reports so far

    @property
    def topics(self) -> frozenset[str]:
        return frozenset(self._states)

    def eligible(self, topic: str) -> Eligible | None:
        state = self._states.get(topic)
        return state.topic if state is not None else None

    def mode(self, topic: str) -> str | None:
        state = self._states.get(topic)
        return state.mode if state is not None else None

    def source(self, topic: str) -> str | None:
        state = self._states.get(topic)
        return state.source if state is not None else None

    def sources(self) -> frozenset[str]:
        """The nodes whose reports are used now."""
        with self._lock:
            return frozenset(
                s.source for s in self._states.values() if s.mode == REPORTED and s.source
            )

    def from_statistics(self) -> int:
        """How many topics are taken from reports now."""
        with self._lock:
            return sum(1 for s in self._states.values() if s.mode == REPORTED)

    def report(self, now: float, report: Report) -> None:
        """A trusted report (:func:`refusal` found nothing) that came at host time ``now``."""
        with self._lock:
            state = self._states.get(report.topic)
            if state is None:
                return
            sub = node_name(report.node_sub)
            heard = state.heard.setdefault(sub, _Heard())
            if report.span > state.topic.max_window_s:
                heard.streak = 0
                if state.mode == WAITING or state.source == sub:
                    self._direct(
                        state,
                        now,
                        f"{sub} reports it every {report.span:.1f} s, too far apart to time it "
                        "by (/statistics_window_max_size)",
                    )
                return
            pub = node_name(report.node_pub)
            last_stop = heard.stops.get(pub)
            heard.stops[pub] = report.window_stop
            heard.streak = heard.streak + 1 if now <= heard.due() else 1
            heard.last = now
            heard.windows.append(report.span)
            heard.longest = max(heard.longest, report.span)
            self._down.discard(sub)
            if last_stop is None or abs(report.window_start - last_stop) > CONTINUES_S:
                heard.streak = 0  # a connection's first window: its count does not fit it
                return
            if state.mode == WAITING or (
                state.mode == DIRECT and not state.paced and heard.streak >= RETURN_REPORTS
            ):
                self._take(state, sub, now)
            if state.source == sub and state.paced:
                # Fed evenly over its window's length, ending D after it came; from where the
                # last one ended if it continues that one (a late report's messages then
                # come at once, as late messages would).
                # A delay that moved with each window would stretch or squeeze the window
                # between (clumps make them 1-1.4 s): it only grows, by DELAY_GROWTH of a
                # window at a time, towards the longest window and the lag.
                target = heard.longest + PACE_LAG_S
                grown = state.delay + DELAY_GROWTH * report.span if state.delay else target
                state.delay = max(state.delay, min(target, grown))
                end = now + state.delay
                last = state.fed.get(pub)
                start = end - report.span
                if last is not None and abs(report.window_start - last[0]) <= CONTINUES_S:
                    start = min(last[1], end)
                state.fed[pub] = (report.window_stop, end)
                self._pacer.add(report.topic, start, end, report.delivered)

    def _take(self, state: _State, sub: str, now: float) -> None:
        """Take the topic from ``sub``'s reports; the host's own messages count until the
        first reported one is fed."""
        was = state.mode
        state.mode, state.source, state.paced = REPORTED, sub, True
        state.fed.clear()
        state.delay = 0.0
        self._lines.append(
            f"t={self.wall(now):.3f} {state.topic.topic}: from /statistics ({sub}'s reports)"
        )
        if was != DIRECT:
            state.own = False

    def _direct(self, state: _State, now: float, why: str) -> None:
        """Receive the topic; the reported messages still count until the first of the
        host's own arrives."""
        if state.mode == DIRECT:
            return
        was = state.mode
        state.mode, state.asked = DIRECT, now
        for heard in state.heard.values():
            heard.streak = 0
        topic = state.topic.topic
        if not state.own:  # not still subscribed from before (a return not yet handed over)
            self._subscribe.append(topic)
            state.own = True
        # The source's reports (late ones too) are fed until the host's own messages come.
        state.paced = was == REPORTED
        if not state.paced:
            state.source = None
        self._lines.append(f"t={self.wall(now):.3f} {topic}: received directly ({why})")

    def node_running(self, node: str, running: bool | None, now: float) -> None:
        """The host's latest sample of whether ``node`` runs (None: unknown): a source
        that does not run is left at once."""
        name = node_name(node)
        with self._lock:
            if running is not False:
                if running:
                    self._down.discard(name)
                return
            if name in self._down:
                return
            self._down.add(name)
            for state in self._states.values():
                if state.mode == REPORTED and state.source == name:
                    self._direct(state, now, f"its source {name} is not running")

    def direct(self, topic: str, now: float) -> bool:
        """Whether messages of ``topic`` the host received itself at ``now`` count; the
        first that counts once the topic is received ends the feeding of reports."""
        state = self._states.get(topic)
        if state is None:
            return True
        with self._lock:
            if not state.own:
                return False
            if state.mode == DIRECT and state.paced:
                state.paced, state.source = False, None
                state.fed.clear()
                state.delay = 0.0
                dropped = self._pacer.cancel(topic)
                self._lines.append(
                    f"t={self.wall(now):.3f} {topic}: its own messages arrive, "
                    f"{now - state.asked:.2f} s after it was subscribed ({dropped} reported "
                    "ones left unfed)"
                )
            return True

    def tick(self, now: float) -> FeedStep:
        """What is due at ``now``: reported messages to feed, subscriptions to make or end."""
        with self._lock:
            for state in self._states.values():
                if state.mode == WAITING and now - self.start >= START_S:
                    self._direct(state, now, f"no trusted report within {START_S:g} s")
                elif (
                    state.mode == REPORTED
                    and state.source is not None
                    and now > state.heard[state.source].due()
                ):
                    self._direct(
                        state,
                        now,
                        f"{state.source}'s reports stopped: a subscriber that stops "
                        "is no topic that stopped",
                    )
            feed, retime = [], []
            for topic, n in self._pacer.take(now):
                state = self._states[topic]
                if not state.paced:
                    continue
                feed.append((topic, n))
                if state.mode == REPORTED and state.own:  # handed over: own messages end
                    state.own = False
                    self._unsubscribe.append(topic)
                    retime.append(topic)
                    self._lines.append(f"t={self.wall(now):.3f} {topic}: received no longer")
            self.reported += sum(n for _, n in feed)
            step = FeedStep(
                tuple(feed),
                tuple(retime),
                tuple(self._subscribe),
                tuple(self._unsubscribe),
                tuple(self._lines),
            )
            self._subscribe, self._unsubscribe, self._lines = [], [], []
            return step
