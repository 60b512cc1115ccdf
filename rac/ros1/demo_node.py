"""One node of the demo robot as a rospy process (see :mod:`rac.runtime.demo`)."""

from __future__ import annotations

import os
import subprocess
from typing import Any

from rac.load.secret import load_secret
from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC
from rac.ros1.common import log_to_ros, raw_class, require_ros, to_array
from rac.runtime.body import start_body
from rac.runtime.demo import DemoNode, DemoRunner, LiveTopic
from rac.runtime.status import rows_from_array


def run_demo_node(demo: DemoNode, body: subprocess.Popen[str] | None = None) -> None:
    """Run the node; ``body``: its body, when the caller started it already."""
    # The body's command line names the node: the pid getPid answers must be proven to be
    # the node's (rac.runtime.placement) before racc watches it.
    if body is None:
        body = start_body([f"__name:={demo.name.strip('/').rpartition('/')[2]}"])
    rospy = require_ros()
    import rospy.impl.masterslave as masterslave
    from diagnostic_msgs.msg import DiagnosticArray

    masterslave.ROSHandler.getPid = lambda _self, _caller: (1, "", body.pid)
    rospy.init_node(demo.name)
    pubs = {
        t.name: rospy.Publisher(
            t.name, raw_class(t.ros_type, t.md5sum, t.definition), queue_size=20
        )
        for t in demo.topics
    }
    for name in demo.subscribes:  # a real subscriber, so the graph shows it
        rospy.Subscriber(name, rospy.AnyMsg, lambda _msg: None, queue_size=1)
    status_pub = (
        rospy.Publisher(DIAGNOSTICS_TOPIC, DiagnosticArray, queue_size=5) if demo.reports else None
    )

    def publish(topic: LiveTopic, now: float) -> None:
        pub = pubs[topic.name]
        pub.publish(pub.data_class(demo.message(topic, now)))

    def status(rows: Any) -> None:
        if status_pub is not None:
            status_pub.publish(to_array(rows))

    key = load_secret() if demo.devices else None  # the board client seals what it sees
    runner = DemoRunner(demo, body, publish, status, log_to_ros(rospy), key)
    if runner.channels:
        rospy.Subscriber(
            BOARD_TOPIC,
            DiagnosticArray,
            lambda a: runner.board_rows(rows_from_array(a), a.header.frame_id),
            queue_size=5,
        )
    rospy.loginfo(
        "demo node %s: publishes %s", demo.name, ", ".join(t.name for t in demo.topics) or "nothing"
    )
    while not rospy.is_shutdown():
        if not runner.step():
            os._exit(1)
