"""The ROS 2 observer host's receiving thread (rac.ros2.receive) on real rclpy: raw
subscriptions that no executor waits on, taken from in batches, with the count of the
publishers DDS has matched."""

from __future__ import annotations

import time

import pytest
from live_harness import ROS2, Ros

from rac.ros2.common import sensor_qos
from rac.ros2.receive import Batch, PollingReceiver, raw_subscription


@pytest.mark.parametrize("ros", [ROS2], ids=[ROS2.id])
def test_messages_are_taken_in_batches_without_an_executor(ros: Ros) -> None:
    import rclpy
    from rclpy.context import Context
    from rclpy.serialization import deserialize_message
    from std_msgs.msg import String

    context = Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node("racc_receive_probe", context=context)
        got: list[Batch] = []
        receiver = PollingReceiver(got.append, raw_subscription(node, sensor_qos), poll_s=0.05)
        handle = receiver.subscribe("/racc_receive_probe", String, 200)
        publisher = node.create_publisher(String, "/racc_receive_probe", sensor_qos(200))
        deadline = time.monotonic() + 10.0
        while handle.get_publisher_count() < 1 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert handle.get_publisher_count() == 1
        second = node.create_publisher(String, "/racc_receive_probe", sensor_qos(10))
        while handle.get_publisher_count() < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert handle.get_publisher_count() == 2  # what the host's gate compares
        node.destroy_publisher(second)
        receiver.start()
        for k in range(100):
            publisher.publish(String(data=f"m{k}"))
            time.sleep(0.002)
        while sum(len(b.raws) for b in got) < 100 and time.monotonic() < deadline:
            time.sleep(0.05)
        raws = [raw for batch in got for raw in batch.raws]
        assert [deserialize_message(r, String).data for r in raws] == [f"m{k}" for k in range(100)]
        assert {b.topic for b in got} == {"/racc_receive_probe"}
        assert len(got) < 50  # several messages a pass, not a call each
        assert receiver.cpu_s > 0
        receiver.unsubscribe("/racc_receive_probe")
        before = len(got)
        publisher.publish(String(data="after"))
        time.sleep(0.3)
        assert len(got) == before and receiver.take_errors() == []
        receiver.stop()
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
