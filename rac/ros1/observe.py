"""The observer host node (``racc observe``): every observer in one rospy process.

What it subscribes is this file's; the sample loop, the agent's turn and the publication
rule are :func:`rac.runtime.nodes.run_observer_node`'s, shared with ROS 2.

**Whose messages count** (:mod:`rac.runtime.sources`).  Every message of a ROS 1
connection carries the connection header its publisher sent: its ``callerid`` and its
``type``.  A publisher can write any ``callerid``, so a connection is judged once, on its
first message: its type must be the model's, its ``callerid`` one of the topic's
publishers in the model, and the XML-RPC URI the host connected to (the publisher the
master announced) the one the master has for that ``callerid``.  A connection that fails
is closed (a stranger's flood costs the host one message) and reported once; rospy opens
it again only when the master announces the publisher again, and it is closed again at
its first message.

**Topics taken from their subscribers' statistics** (:mod:`rac.ros1.topic_statistics`).
With ``--statistics auto``, when the robot runs with ``/enable_statistics``, a
topic watched only for its rate and liveness, which a node of the model subscribes, is not
subscribed here while a trusted subscriber's reports on ``/statistics`` say how many
messages it carried; it is subscribed when none do.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC, ObserverSpec, TopicSource
from rac.ros1.agent import start_agent
from rac.ros1.common import Ros1Bus, header_type, node_liveness, node_uri
from rac.ros1.tcpros import Batch, LeanReceiver, install
from rac.ros1.topic_statistics import OFF, StatisticsReceiver, statistics_on
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.host import ObserverHost
from rac.runtime.nodes import run_observer_node
from rac.runtime.procs import DEFAULT_SETTLE_S, ProcessProbe
from rac.runtime.sources import SourceCheck
from rac.runtime.status import rows_from_array
from rac.runtime.topic_statistics import eligible_topics
from rac.runtime.trust import OBSERVER
from rac.runtime.values import Readers

LOOKUP_RETRY_S = 1.0  # a connection the master could not vouch for is asked about again


class Connections:
    """Which ROS 1 connections of the subscribed topics count (module docstring).

    ``lookup(callerid)`` is the master's URI of a node (None: it has none; raises OSError
    when the master does not answer).  Not locked: each connection's messages arrive on
    its own thread, and a verdict is a value (judging one twice gives the same answer).
    """

    def __init__(
        self,
        check: SourceCheck,
        refuse: Callable[[str, str, str], None],
        lookup: Callable[[str], str | None],
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.check, self.refuse, self.lookup, self.clock = check, refuse, lookup, clock
        self._verdicts: dict[int, tuple[Any, bool]] = {}  # id(header) -> (header, verdict)
        self._retry: dict[int, float] = {}  # id(header) -> when to ask the master again

    def admits(self, topic: str, header: Any, impl: Any, any_publisher: bool = False) -> bool:
        """Whether a message with connection ``header`` on ``topic`` counts; ``impl`` is
        the topic's rospy subscriber (its connections); ``any_publisher``: the topic has
        many publishers by design (``/diagnostics``), only a forged callerid is refused."""
        if not isinstance(header, dict):
            return not self.check.known
        hit = self._verdicts.get(id(header))
        if hit is not None and hit[0] is header:
            return hit[1]
        verdict = self._judge(topic, header, impl, any_publisher)
        if verdict is not None:
            if len(self._verdicts) > 1000:
                self._verdicts.clear()  # connections of the past: judged again if they come
            self._verdicts[id(header)] = (header, verdict)
        return bool(verdict)

    def _judge(self, topic: str, header: dict[str, Any], impl: Any, anyone: bool) -> bool | None:
        callerid = str(header.get("callerid", ""))
        why = None if anyone else self.check.reason(topic, callerid, str(header.get("type", "")))
        connection = next(
            (c for c in list(getattr(impl, "connections", ())) if c.header is header), None
        )
        if why is None and callerid and connection is not None:
            retry = self._retry.get(id(header), 0.0)
            if self.clock() < retry:
                return None
            try:
                uri = self.lookup(callerid)
            except OSError:
                self._retry[id(header)] = self.clock() + LOOKUP_RETRY_S
                return None  # the master does not answer: nothing counts until it does
            self._retry.pop(id(header), None)
            if uri is None or uri.rstrip("/") != str(connection.endpoint_id).rstrip("/"):
                why = (
                    f"its connection says it is {callerid}, but the master has "
                    f"{callerid} at {uri or 'no address'}, not at {connection.endpoint_id} "
                    "(a forged callerid)"
                )
        if why is None:
            return True
        self.refuse(callerid, topic, why)
        if connection is not None:
            # A stranger's flood stops here; rospy's own bookkeeping may fail, the verdict
            # stands either way.
            with contextlib.suppress(Exception):
                impl.remove_connection(connection)
        return False


def run_observe(
    specs: Sequence[ObserverSpec],
    *,
    sample_hz: float = 10.0,
    republish_s: float = 1.0,
    name: str = "racc_observer",
    machine: str | None = None,
    launch: str | None = None,
    settle_s: float = DEFAULT_SETTLE_S,
    key: bytes | None = None,
    sources: dict[str, TopicSource] | None = None,
    robot_gone_s: float = DEFAULT_GONE_S,
    statistics: str = OFF,
) -> None:
    bus = Ros1Bus(name, key, OBSERVER)
    rospy = bus.rospy
    from diagnostic_msgs.msg import DiagnosticArray

    host = ObserverHost(specs, sources=sources)
    host.source = bus.name
    trust = bus.trust
    refuse = trust.refuse if trust is not None else host.refuse
    agent = start_agent(bus, specs, machine, launch, robot_gone_s)
    bank = host.bank
    readers = Readers(bank.topic_fields())
    connections = Connections(host.check, refuse, node_uri)
    impls: dict[str, Any] = {}

    def describe(topic: str, connection: Any) -> tuple[bool, bool]:
        """(stamped, keep the bytes) of a topic, from its first connection's header."""
        reader = readers.reader(topic, lambda: header_type(connection.header))
        return reader.stamped, reader.reads_fields

    def on_batch(batch: Batch) -> None:
        topic, connection = batch.topic, batch.connection
        if not connections.admits(topic, connection.header, impls[topic]):
            return
        if reports is not None and not reports.feed.direct(topic, host.clock()):
            return  # taken from its subscribers' reports (a subscription being ended)
        values: list[Mapping[str, float]] = []
        if batch.bodies:
            reader = readers.reader(topic, lambda: header_type(connection.header))
            values = [reader.values(body) for body in batch.bodies]
        host.messages(topic, batch.count, batch.stamps, values, batch.seqs)

    def subscribe(topic: str) -> Any:
        # rospy registers the subscription and makes its connections; their messages go
        # to the receiver, never to this callback.
        sub = rospy.Subscriber(topic, rospy.AnyMsg, _unused, queue_size=1)
        impls[topic] = sub.impl
        return sub

    receiver = LeanReceiver(on_batch, describe)
    host.path_cpu = lambda: receiver.cpu_s
    install(receiver, bank.topic_fields())
    on, why = statistics_on(rospy, statistics)
    eligible = eligible_topics(bank, sources) if on else {}
    reports: StatisticsReceiver | None = None
    if eligible:
        reports = StatisticsReceiver(host, eligible, connections, refuse, subscribe, bus.log)
        reports.listen(rospy)
    bus.log(
        0,
        f"racc observe: topic statistics {why}"
        + (f": {len(eligible)} topics may be taken from their subscribers' reports" if on else ""),
    )
    for topic in sorted(bank.topic_fields()):
        if topic not in eligible:  # those wait for their reports (StatisticsFeed)
            subscribe(topic)
    if bank.devices:

        def on_diagnostics(array: Any) -> None:
            header = getattr(array, "_connection_header", None)
            if not connections.admits(DIAGNOSTICS_TOPIC, header, diagnostics.impl, True):
                return
            source = str(header.get("callerid", "")) if isinstance(header, dict) else None
            host.device_rows(rows_from_array(array), source)

        diagnostics = rospy.Subscriber(DIAGNOSTICS_TOPIC, DiagnosticArray, on_diagnostics)
    if bank.needs_board:
        bus.on_rows(
            BOARD_TOPIC,
            host.channel_rows,
            10,
            gate=trust.gate(BOARD_TOPIC) if trust is not None else None,
        )
    probe = ProcessProbe(bank.nodes, node_liveness, bank.properties, settle_s=settle_s)
    run_observer_node(
        bus,
        host,
        probe,
        topics=len(bank.topic_fields()),
        sample_hz=sample_hz,
        republish_s=republish_s,
        agent=agent,
        machine=machine,
        each_tick=(lambda now: reports.each_tick(probe)) if reports is not None else None,
    )


def _unused(msg: Any) -> None:
    """The lean subscriptions' rospy callback: never called (rac.ros1.tcpros)."""
