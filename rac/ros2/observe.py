"""The observer host node on ROS 2 (``racc observe --ros 2``): every observer in one
rclpy process.

Topics are subscribed as they appear in the graph (raw CDR, best effort, with the type the
model declares, else the one the graph names; only the fields an observer reads are
deserialized, with rosbags).  Their messages do not go through rclpy's executor: one
thread takes what waits on every subscription every 50 ms and hands each topic's messages
to the frequency observers as one batch (:mod:`rac.ros2.receive`).

**Whose messages count** (:mod:`rac.runtime.sources`).  rclpy does not say which publisher
sent a message, so the graph does: once a second the host reads each observed topic's
publishers.  One of another type never reaches the host (DDS matches a subscription only
with publishers of its type): it is reported.  One of the declared type that the model
does not name cannot be told apart from the model's own: the topic's observers are
suspended (their atoms unknown, never a fault) while it publishes, and start again when
it has gone; it is reported.  DDS matches a publisher before it delivers and before the
graph names its node: a topic whose subscription has matched more publishers than the
last audit judged counts none of its messages until the next audit (within 0.1 s).
Within an SROS2 enclave whose policy lets only the model's nodes publish, neither happens
(docs/security.md).  NObs:
the graph (``get_node_names_and_namespaces``) and the node's process, found by its
``__node:=`` argument (:class:`rac.ros2.common.PidResolver`); PObs: cpu and memory of that
process.  The sample loop, the agent's turn and the publication rule
are :func:`rac.runtime.nodes.run_observer_node`'s, shared with ROS 1.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC, ObserverSpec, TopicSource
from rac.ros2.agent import start_agent
from rac.ros2.common import PidResolver, Session, graph_nodes, message_class, sensor_qos
from rac.ros2.receive import Batch, PollingReceiver, depth_for, raw_subscription
from rac.runtime.guardian import DEFAULT_GONE_S
from rac.runtime.host import ObserverHost
from rac.runtime.nodes import run_observer_node
from rac.runtime.procs import DEFAULT_SETTLE_S, ProcessProbe
from rac.runtime.routing import RACC_PREFIX
from rac.runtime.sources import node_name, type_name
from rac.runtime.status import rows_from_array
from rac.runtime.trust import OBSERVER
from rac.runtime.values import Readers

DISCOVER_S = 0.5
AUDIT_S = 1.0  # how often the graph's publishers of the observed topics are checked
UNNAMED_S = 2.0  # an endpoint unnamed this long is reported (discovery names it sooner)
SOON_S = 0.1  # the next audit, after a publisher matched that the last one did not judge
UNNAMED = "_NODE_NAME_UNKNOWN_"  # the graph's name of an endpoint whose node is not known yet


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
) -> None:
    session = Session(name, key=key, role=OBSERVER)
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy import exceptions as rclpy_errors

    destroyed = getattr(rclpy_errors, "InvalidHandle", RuntimeError)  # Jazzy's, else older

    node = session.node
    host = ObserverHost(specs, sources=sources)
    host.source = session.name
    agent = start_agent(session, specs, machine, launch, robot_gone_s)
    bank = host.bank
    readers = Readers(bank.topic_fields(), ros_version=2)
    wanted = frozenset(bank.topic_fields())
    subs: dict[str, Any] = {}
    kinds: dict[str, str] = {}  # topic -> the type it is subscribed with
    graph_types: dict[str, str] = {}  # topic -> the type the graph names (its values' reader)
    # A topic's rate in the model sizes its subscription's queue between two passes.
    rates = {
        str(dict(o.params)["topic"]): 1.0 / float(dict(o.params)["delta"])
        for o in specs
        if o.kind == "GObs" and float(dict(o.params).get("delta") or 0.0) > 0
    }
    unknown: set[str] = set()
    next_discover = next_audit = 0.0

    check = host.check
    trust = session.trust
    refuse = trust.refuse if trust is not None else host.refuse
    if trust is not None:
        host.refuse = trust.refuse

    def on_batch(batch: Batch) -> None:
        """What one pass took from ``batch.topic``'s subscription (the receiving thread)."""
        topic = batch.topic
        if topic in host.suspended:
            return  # whose it is cannot be told: nothing of it is read
        sub = subs.get(topic)
        try:
            matched = sub.get_publisher_count() if sub is not None and check.known else 0
        except destroyed:
            return  # parked during the pass: its subscription is gone
        if matched > vetted.get(topic, 0):
            # A publisher matched since the last audit (DDS matches before it delivers, the
            # graph may name it later): until the audit has judged it, no message of the
            # topic counts, so that a stranger's first messages count for nothing.  Before
            # the topic's first message there is nothing to suspend: its observers have not
            # spoken (the robot's own publishers, found at start).
            if topic in heard:
                host.suspend_topic(topic, "a publisher not judged yet")
            audit_soon()
            return
        heard.add(topic)
        reader = readers.reader(topic, lambda: (graph_types[topic], ""))
        raws = batch.raws
        stamps = [reader.stamp(raw) for raw in raws] if reader.stamped else []
        values = [reader.values(raw) for raw in raws] if reader.reads_fields else []
        host.messages(topic, len(raws), stamps, values)

    receiver = PollingReceiver(on_batch, raw_subscription(node, sensor_qos))
    host.path_cpu = lambda: receiver.cpu_s

    def subscribe(topic: str, ros_type: str) -> None:
        declared = check.declared_type(topic)
        cls = message_class(declared) if declared else None
        if cls is None:
            if declared and declared not in unknown:
                unknown.add(declared)
                session.log(
                    1,
                    f"racc observe: {topic}: the declared type {declared} is not importable "
                    f"here; subscribed as {ros_type}, as the graph names it",
                )
            cls = message_class(ros_type)
        if cls is None:
            if ros_type not in unknown:
                unknown.add(ros_type)
                session.log(1, f"racc observe: {topic}: type {ros_type} is not importable")
            return

        kinds[topic] = ros_type if not declared or message_class(declared) is None else declared
        graph_types[topic] = ros_type
        subs[topic] = receiver.subscribe(topic, cls, depth_for(rates.get(topic)))
        if check.known:
            audit_topic(topic)  # before its first message: the publishers the graph shows now

    parked: dict[str, Any] = {}  # contested topics: unsubscribed meanwhile, and their type

    def park(topic: str) -> None:
        """A contested topic's messages are not read: while a stranger floods it, its
        subscription is dropped, so that DDS delivers none of them to this process."""
        if topic in subs and topic not in parked:
            receiver.unsubscribe(topic)
            parked[topic] = graph_types.get(topic, "")

    def unpark(topic: str) -> None:
        kind = parked.pop(topic, None)
        if kind is not None:
            subscribe(topic, kind)

    def discover(now: float) -> None:
        nonlocal next_discover
        if now < next_discover or len(subs) == len(wanted):
            return
        next_discover = now + DISCOVER_S
        for topic, types in node.get_topic_names_and_types():
            if topic in wanted and topic not in subs and types:
                declared = check.declared_type(topic)
                # The declared type's publishers, whatever else publishes on the name.
                matching = [t for t in types if declared and type_name(t) == declared]
                subscribe(topic, (matching or types)[0])

    unnamed: dict[tuple[str, str], float] = {}  # (topic, gid) -> when first seen unnamed

    def publishers(topic: str) -> list[tuple[str, str, bool, bool]]:
        """(node, type, named, reported) of each publisher of ``topic`` in the graph.
        Discovery tells an endpoint before its node's name: such an endpoint counts as a
        stranger (its messages cannot be told apart) but is reported only once it has
        stayed unnamed for UNNAMED_S."""
        out = []
        now = time.monotonic()
        for info in node.get_publishers_info_by_topic(topic):
            named = UNNAMED not in info.node_name
            name = f"{info.node_namespace.rstrip('/')}/{info.node_name}".lstrip("/")
            key = (topic, str(list(info.endpoint_gid)))
            reported = named or now - unnamed.setdefault(key, now) >= UNNAMED_S
            if not named:
                name = "an endpoint whose node is not named"
            out.append((name, info.topic_type, named, reported))
        return out

    heard: set[str] = set()  # topics a message of which counted
    vetted: dict[str, int] = {}  # topic -> its publishers the last audit found all the model's

    def audit_soon() -> None:
        nonlocal next_audit
        next_audit = min(next_audit, time.time() + SOON_S)  # the ticks' clock

    def audit_topic(topic: str) -> None:
        """The graph's publishers of ``topic`` against the model's."""
        contested, unseen, unnamed_yet = [], False, False
        declared = check.declared_type(topic)
        kind_of_sub = kinds.get(topic, "")
        checks_type = declared is not None and kind_of_sub == declared
        same_type = 0
        for publisher, kind, named, reported in publishers(topic):
            same = type_name(kind) == type_name(kind_of_sub)
            same_type += same
            why = check.stranger(topic, publisher) if named else "not named in the graph"
            if checks_type and not why:
                why = check.wrong_type(topic, kind)
            if why is None:
                continue
            if not reported:
                # Not named yet, as a robot's own node that has just (re)started: judged
                # again soon; meanwhile the publishers counted at the last audit go on
                # counting, and the gate drops the topic's messages if there are more.
                unnamed_yet = True
                continue
            refuse(publisher, topic, why)
            if same:
                contested.append(f"{publisher} publishes it too")
        sub = subs.get(topic)
        if sub is not None and topic not in parked and sub.get_publisher_count() > same_type:
            unseen = True  # matched by DDS, not in the graph yet: judged at the next audit
        if contested or unseen:
            # Not vetted: the gate drops the topic's messages.  Its observers are suspended
            # only once they have heard it (before, they have said nothing to take back).
            vetted.pop(topic, None)
            if topic in heard:
                host.suspend_topic(
                    topic, "; ".join(contested) or "a publisher not in the graph yet"
                )
            if contested:
                park(topic)
        elif not unnamed_yet:
            vetted[topic] = same_type
            host.resume_topic(topic)
            unpark(topic)  # subscribes again, and judges the topic's publishers once more
        if unseen or unnamed_yet:
            audit_soon()  # discovery names a robot's own endpoints within moments

    def audit(now: float) -> None:
        """The graph's publishers of each observed topic against the model's."""
        nonlocal next_audit
        if now < next_audit or not check.known:
            return
        next_audit = now + AUDIT_S
        for topic in sorted(subs):
            audit_topic(topic)
        if bank.devices:
            # Whose status a /diagnostics message is cannot be told here: while a node that
            # is neither the model's nor racc's publishes there, the device observers are
            # suspended (docs/security.md).
            known = {node_name(n) for n in bank.nodes}
            strangers = []
            for publisher, _, named, reported in publishers(DIAGNOSTICS_TOPIC):
                if named and (publisher in known or publisher.startswith(RACC_PREFIX)):
                    continue
                strangers.append(publisher)
                if reported:
                    refuse(
                        publisher,
                        DIAGNOSTICS_TOPIC,
                        "not a node of the model: whose status a message is cannot be told "
                        "on ROS 2, so the device observers wait",
                    )
            if strangers:
                host.suspend_topic(DIAGNOSTICS_TOPIC, f"{', '.join(strangers)} publish there too")
            else:
                host.resume_topic(DIAGNOSTICS_TOPIC)

    def each_tick(now: float) -> None:
        discover(now)
        audit(now)
        for error in receiver.take_errors():
            session.log(2, f"racc observe: receiving {error}")

    if bank.devices:
        # Who published a status is not told here: every status counts (docs/security.md).
        node.create_subscription(
            DiagnosticArray,
            DIAGNOSTICS_TOPIC,
            lambda a: host.device_rows(rows_from_array(a)),
            sensor_qos(),
        )
    if bank.needs_board:
        session.on_rows(
            BOARD_TOPIC,
            host.channel_rows,
            10,
            gate=trust.gate(BOARD_TOPIC) if trust is not None else None,
        )
    resolver = PidResolver(lambda: graph_nodes(session))
    probe = ProcessProbe(bank.nodes, resolver, bank.properties, recheck_s=1.0, settle_s=settle_s)
    receiver.start()
    try:
        run_observer_node(
            session,
            host,
            probe,
            topics=len(wanted),
            sample_hz=sample_hz,
            republish_s=republish_s,
            agent=agent,
            machine=machine,
            each_tick=each_tick,
        )
    finally:
        receiver.stop()
        session.close()
