"""One node of the demo robot as a rospy process (see :mod:`rac.runtime.demo`)."""

from __future__ import annotations

import heapq
import os
import subprocess
import sys
import threading
import time
from typing import Any

from rac.passes.observers import BOARD_TOPIC, DIAGNOSTICS_TOPIC
from rac.ros1.common import from_array, raw_class, require_ros, to_array
from rac.runtime.demo import STATUS_HZ, DemoNode
from rac.runtime.status import ERROR, OK, Row, row_channel

# The node's "body": a small companion process whose pid the node reports through getPid,
# so that the observers' cpu and memory readings are those of a process the size of a real
# driver (a Python ROS node alone is larger than most nodes' memory limits).  cpu and mem
# faults act on it; it ends with its node (its stdin closes).
BODY = """
import os, sys, threading, time
state = {"cpu": 0.0, "mem": 0}
held = []
def read():
    for line in sys.stdin:
        key, _, value = line.partition(" ")
        state[key] = float(value)
    os._exit(0)
threading.Thread(target=read, daemon=True).start()
while True:
    want = int(state["mem"])
    if want and not held:
        block = bytearray(want)
        for i in range(0, want, 4096):
            block[i] = 1
        held.append(block)
    elif not want:
        held.clear()
    burn = min(max(state["cpu"], 0.0), 0.95)
    until = time.time() + burn * 0.1
    while time.time() < until:
        pass
    time.sleep(0.1 * (1 - burn))
"""


def start_body() -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-S", "-c", BODY], stdin=subprocess.PIPE, text=True, bufsize=1
    )


def run_demo_node(demo: DemoNode) -> None:
    rospy = require_ros()
    import rospy.impl.masterslave as masterslave
    from diagnostic_msgs.msg import DiagnosticArray

    body = start_body()
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
    lost = threading.Event()  # a device of this driver lost power: until restarted
    channels = {channel for _, channel in demo.devices}
    if channels:

        def on_board(array: Any) -> None:
            for row in from_array(array):
                state = row_channel(row, 0.0)
                if state is not None and state.channel in channels and not state.on:
                    if not lost.is_set():
                        rospy.logwarn(
                            "t=%.3f lost the device on channel %d", time.time(), state.channel
                        )
                    lost.set()

        rospy.Subscriber(BOARD_TOPIC, DiagnosticArray, on_board, queue_size=5)
    status_pub = (
        rospy.Publisher(DIAGNOSTICS_TOPIC, DiagnosticArray, queue_size=5) if demo.reports else None
    )
    told = (0.0, 0)
    now = time.time()
    queue = [(now, i) for i in range(len(demo.topics))]
    heapq.heapify(queue)
    next_status = now
    rospy.loginfo(
        "demo node %s: publishes %s", demo.name, ", ".join(t.name for t in demo.topics) or "nothing"
    )
    while not rospy.is_shutdown():
        now = time.time()
        if demo.crashed(now):
            rospy.logerr("t=%.3f demo fault: %s crashes", now, demo.name)
            os._exit(1)
        wanted = (demo.cpu_burn(now), demo.mem_hold(now))
        if wanted != told and body.stdin is not None:
            body.stdin.write(f"cpu {wanted[0]}\nmem {wanted[1]}\n")
            told = wanted
        if status_pub is not None and now >= next_status:
            level = ERROR if lost.is_set() else OK
            rows = [
                Row(f"{demo.name}: {d}", level, "lost" if lost.is_set() else "ok", d)
                for d in demo.reports
            ]
            status_pub.publish(to_array(rows))
            next_status = now + 1.0 / STATUS_HZ
        while queue and queue[0][0] <= now:
            due, i = heapq.heappop(queue)
            topic = demo.topics[i]
            if not lost.is_set():
                pubs[topic.name].publish(pubs[topic.name].data_class(demo.message(topic, now)))
            nxt = due + 1.0 / demo.rate(topic, now)
            heapq.heappush(queue, (max(nxt, now - 0.5), i))
        wake = min(queue[0][0] if queue else now + 0.1, now + 0.1)
        if status_pub is not None:
            wake = min(wake, next_status)
        delay = wake - time.time()
        if delay > 0:
            time.sleep(delay)
