"""One node of the demo robot as an rclpy process (see :mod:`rac.runtime.demo`).

Messages are serialized to CDR with rosbags and published raw on publishers of the
topic's generated type; a type whose package this Python cannot import (a robot's own
messages, e.g. ``tedusar_msgs/msg/ServoState``) is published as the stand-in
``std_msgs/msg/Float64MultiArray`` (:meth:`DemoNode.stand_in`).
"""

from __future__ import annotations

import os
import subprocess
from typing import Any

from rac.load.secret import load_secret
from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC
from rac.ros2.args import ROS_ARGS
from rac.ros2.common import (
    Session,
    message_class,
    reliable,
    sensor_qos,
    to_array,
)
from rac.runtime.body import start_body
from rac.runtime.demo import STAND_IN, DemoNode, DemoRunner, LiveTopic
from rac.runtime.status import rows_from_array


def run_demo_node(demo: DemoNode, body: subprocess.Popen[str] | None = None) -> None:
    """Run the node; ``body``: its body, when the caller started it already."""
    if body is None:
        # The body carries this node's ROS arguments: found by its ``__node:=`` (innermost).
        marker = ROS_ARGS if ROS_ARGS else ["--ros-args", "-r", f"__node:={demo.name}"]
        body = start_body(marker)
    session = Session(demo.name)
    node = session.node
    from diagnostic_msgs.msg import DiagnosticArray

    pubs: dict[str, Any] = {}
    stand_ins: set[str] = set()
    for t in demo.topics:
        cls = message_class(t.typename)
        if cls is None:
            session.log(1, f"demo node {demo.name}: {t.name} ({t.typename}) as {STAND_IN}")
            cls = message_class(STAND_IN)
            stand_ins.add(t.name)
        pubs[t.name] = node.create_publisher(cls, t.name, reliable(20))
    for name in demo.subscribes:  # a real subscriber, so the graph shows it
        ros_type = demo.topic_types.get(name, "")
        cls = message_class(ros_type) or message_class(STAND_IN)
        node.create_subscription(cls, name, lambda _raw: None, sensor_qos(1), raw=True)
    status_pub = (
        node.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, reliable(5))
        if demo.reports
        else None
    )

    def publish(topic: LiveTopic, now: float) -> None:
        if topic.name in stand_ins:
            pubs[topic.name].publish(demo.stand_in(topic, now))
        else:
            pubs[topic.name].publish(demo.message(topic, now))

    def status(rows: Any) -> None:
        if status_pub is not None:
            status_pub.publish(to_array(session, rows))

    key = load_secret() if demo.devices else None  # the board client seals what it sees
    runner = DemoRunner(demo, body, publish, status, session.log, key)
    if runner.channels:
        node.create_subscription(
            DiagnosticArray,
            BOARD_TOPIC,
            lambda a: runner.board_rows(rows_from_array(a), a.header.frame_id),
            sensor_qos(5),
        )
    shown = ", ".join(t.name for t in demo.topics) or "nothing"
    session.log(0, f"demo node {demo.name}: publishes {shown}")
    try:
        while session.ok:
            if not runner.step():
                os._exit(1)
    finally:
        session.close()
