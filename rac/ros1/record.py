"""The recorder node (``racc record``): every topic into a ROS 1 bag, with the properties
CSV and the computation graph (§9.1.1)."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

from rosbags.rosbag1 import Writer

from rac.learn.graph import Exclusions
from rac.ros1.common import (
    connection_type,
    node_hosts,
    require_ros,
    resolve_pid,
    system_state,
)
from rac.runtime.record import DEFAULT_EXCLUSIONS, PropertySampler, graph_yaml

DISCOVER_S = 0.5
PROPERTY_HZ = 2.0


def run_record(
    bag: Path,
    csv: Path,
    graph: Path,
    duration: float,
    name: str = "racc_recorder",
    exclusions: Exclusions = DEFAULT_EXCLUSIONS,
) -> tuple[int, int]:
    """(messages, topics) recorded: the robot's, without what ``exclusions`` leaves out."""
    rospy = require_ros()
    rospy.init_node(name, anonymous=True)  # racc_recorder_*: left out of its own graph
    me = rospy.get_name()
    lock = threading.Lock()
    writer = Writer(bag)
    writer.open()
    conns: dict[tuple[str, str], Any] = {}
    count = [0]

    def on_message(msg: Any, topic: str) -> None:
        stamp = time.time_ns()
        ros_type, definition = connection_type(msg)
        header = getattr(msg, "_connection_header", {}) or {}
        with lock:
            key = (topic, ros_type)
            conn = conns.get(key)
            if conn is None:
                conn = writer.add_connection(
                    topic,
                    ros_type.replace("/", "/msg/", 1) if "/msg/" not in ros_type else ros_type,
                    msgdef=definition,
                    md5sum=header.get("md5sum", ""),
                    callerid=header.get("callerid"),
                )
                conns[key] = conn
            writer.write(conn, stamp, msg._buff)
            count[0] += 1

    subscribed: dict[str, Any] = {}
    sampler = PropertySampler(resolve_pid)
    rows = ["time,node,cpu,mem"]
    start = time.time()
    next_sample = start
    next_discover = start
    pubs: list[Any] = []
    subs: list[Any] = []
    while not rospy.is_shutdown() and time.time() - start < duration:
        now = time.time()
        if now >= next_discover:
            pubs, subs, _ = system_state()
            for topic, names in pubs:
                if topic not in subscribed and exclusions.topic(topic, names):
                    subscribed[topic] = rospy.Subscriber(
                        topic, rospy.AnyMsg, on_message, callback_args=topic, queue_size=200
                    )
            next_discover = now + DISCOVER_S
        if now >= next_sample:
            names = {n for _, ns in pubs for n in ns} | {n for _, ns in subs for n in ns}
            rows.extend(sampler.rows(now, (n for n in names if n != me and exclusions.node(n))))
            next_sample = now + 1.0 / PROPERTY_HZ
        time.sleep(0.05)
    for sub in subscribed.values():
        sub.unregister()
    time.sleep(0.2)
    with lock:
        writer.close()
    csv.write_text("\n".join(rows) + "\n", encoding="utf-8")
    names = {n for _, ns in [*pubs, *subs] for n in ns if exclusions.node(n)}
    graph.write_text(
        graph_yaml(pubs, subs, [me], exclusions, hosts=node_hosts(names)), encoding="utf-8"
    )
    return count[0], len(conns)
