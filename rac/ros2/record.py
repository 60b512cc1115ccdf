"""The recorder on ROS 2 (``racc record --ros 2``): every topic of the robot's nodes into a
rosbag2 directory (written with rosbags, sqlite3), with the properties CSV and the
computation graph (§9.1.1)."""

from __future__ import annotations

import os
import queue
import threading
import time
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import Writer
from rosbags.typesys import Stores, get_typestore

from rac.learn.graph import INFRASTRUCTURE_TOPICS, Exclusions
from rac.ros2.common import PidResolver, Session, graph_nodes, message_class, sensor_qos
from rac.runtime.record import DEFAULT_EXCLUSIONS, PropertySampler, graph_yaml

DISCOVER_S = 0.5
PROPERTY_HZ = 2.0
SKIPPED = frozenset({"/rosout", "/parameter_events"}) | frozenset(INFRASTRUCTURE_TOPICS)


def _full(name: str, ns: str) -> str:
    return f"{ns.rstrip('/')}/{name}" if ns != "/" else f"/{name}"


def run_record(
    bag: Path,
    csv: Path,
    graph: Path,
    duration: float,
    name: str = "racc_recorder",
    exclusions: Exclusions = DEFAULT_EXCLUSIONS,
) -> tuple[int, int]:
    """(messages, topics) recorded: the robot's, without what ``exclusions`` leaves out."""
    session = Session(f"{name}_{os.getpid()}")  # racc_recorder_*: left out of its graph
    node = session.node
    me = "/" + session.name
    store = get_typestore(Stores.ROS2_HUMBLE)
    writer = Writer(bag, version=8)
    writer.open()
    lock = threading.Lock()
    conns: dict[str, Any] = {}
    subs: dict[str, Any] = {}
    skipped: set[str] = set()
    count = [0]
    pending: queue.Queue[tuple[Any, int, bytes]] = queue.Queue()

    def drain() -> None:
        while not pending.empty():
            writer.write(*pending.get_nowait())
            count[0] += 1

    def subscribe(topic: str, ros_type: str) -> None:
        cls = message_class(ros_type)
        if cls is None or ros_type not in store.fielddefs:
            if topic not in skipped:
                skipped.add(topic)
                session.log(1, f"racc record: {topic} ({ros_type}) is not recorded: unknown type")
            return
        with lock:
            conn = conns[topic] = writer.add_connection(topic, ros_type, typestore=store)

        def on_message(raw: bytes) -> None:
            # The writer's sqlite3 connection belongs to the main thread: queue, write there.
            pending.put((conn, time.time_ns(), raw))

        subs[topic] = node.create_subscription(cls, topic, on_message, sensor_qos(200), raw=True)

    def robot_publishers(topic: str) -> bool:
        infos = node.get_publishers_info_by_topic(topic)
        names = [_full(i.node_name, i.node_namespace) for i in infos]
        return bool(names) and exclusions.topic(topic, names)

    sampler = PropertySampler(PidResolver(lambda: graph_nodes(session)))
    rows = ["time,node,cpu,mem"]
    start = time.time()
    next_sample = next_discover = start
    try:
        while session.ok and time.time() - start < duration:
            now = time.time()
            if now >= next_discover:
                for topic, types in node.get_topic_names_and_types():
                    new = topic not in subs and topic not in skipped and topic not in SKIPPED
                    if new and types and robot_publishers(topic):
                        subscribe(topic, types[0])
                next_discover = now + DISCOVER_S
            if now >= next_sample:
                names = [n for n in graph_nodes(session) if exclusions.node("/" + n)]
                rows.extend(sampler.rows(now, names))
                next_sample = now + 1.0 / PROPERTY_HZ
            drain()
            time.sleep(0.05)
        publishers, subscribers = _graph(node, exclusions)
    finally:
        for sub in subs.values():
            node.destroy_subscription(sub)
        time.sleep(0.1)
        drain()
        writer.close()
        session.close()
    csv.write_text("\n".join(rows) + "\n", encoding="utf-8")
    graph.write_text(graph_yaml(publishers, subscribers, [me], exclusions), encoding="utf-8")
    return count[0], len(conns)


def _graph(
    node: Any, exclusions: Exclusions
) -> tuple[list[tuple[str, list[str]]], list[tuple[str, list[str]]]]:
    """(topic, [node]) pairs of publishers and subscribers, as the master's getSystemState."""
    pubs: dict[str, list[str]] = {}
    subs: dict[str, list[str]] = {}
    for name, ns in node.get_node_names_and_namespaces():
        full = _full(name, ns)
        if not exclusions.node(full):
            continue
        for topic, _ in node.get_publisher_names_and_types_by_node(name, ns):
            pubs.setdefault(topic, []).append(full)
        for topic, _ in node.get_subscriber_names_and_types_by_node(name, ns):
            subs.setdefault(topic, []).append(full)
    return sorted(pubs.items()), sorted(subs.items())
