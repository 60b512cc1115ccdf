"""The ROS 2 receiving thread's bookkeeping, with subscriptions of our own (no ROS): its
queues' depths, one batch per topic and pass, a failing delivery, a re-subscription."""

from __future__ import annotations

from collections import deque
from typing import Any

from rac.ros2.receive import MIN_DEPTH, Batch, PollingReceiver, depth_for


class FakeSubscription:
    """An rcl subscription's surface: ``take_message`` and its destruction."""

    def __init__(self, topic: str, depth: int) -> None:
        self.topic, self.depth = topic, depth
        self.queue: deque[bytes] = deque(maxlen=depth)
        self.destroyed = False

    def take_message(self, msg_type: Any, raw: bool) -> tuple[bytes, dict[str, int]] | None:
        assert raw and not self.destroyed
        return (self.queue.popleft(), {}) if self.queue else None

    def destroy_when_not_in_use(self) -> None:
        self.destroyed = True


def test_a_queue_holds_several_passes_of_the_declared_rate() -> None:
    assert depth_for(None) == depth_for(0.0) == depth_for(float("nan")) == MIN_DEPTH
    assert depth_for(10.0) == MIN_DEPTH  # half a message a pass
    assert depth_for(1000.0) == 200  # 50 a pass, four passes' room
    assert depth_for(1000.0, poll_s=0.01) == 40


def test_one_batch_per_topic_and_pass_and_a_failing_delivery_stops_nothing() -> None:
    made: dict[str, list[FakeSubscription]] = {}

    def make(topic: str, msg_type: Any, depth: int) -> FakeSubscription:
        sub = FakeSubscription(topic, depth)
        made.setdefault(topic, []).append(sub)
        return sub

    got: list[tuple[str, list[bytes]]] = []

    def deliver(batch: Batch) -> None:
        if batch.topic == "/bad":
            raise ValueError("a reader that fails")
        got.append((batch.topic, list(batch.raws)))

    receiver = PollingReceiver(deliver, make)
    imu = receiver.subscribe("/imu", object, depth_for(1000.0))
    receiver.subscribe("/bad", object, 8)
    receiver.subscribe("/quiet", object, 8)
    assert made["/imu"][0].depth == 200
    imu.queue.extend([b"a", b"b", b"c"])
    made["/bad"][0].queue.append(b"x")
    assert receiver.take_all() == 4
    assert got == [("/imu", [b"a", b"b", b"c"])]  # no batch of a topic with nothing waiting
    assert receiver.take_errors() == ["/bad: ValueError: a reader that fails"]
    assert receiver.take_all() == 0 and receiver.take_errors() == []
    # Subscribed again (a parked topic comes back): the old subscription is destroyed.
    again = receiver.subscribe("/imu", object, 32)
    assert made["/imu"][0].destroyed and again is made["/imu"][1]
    receiver.unsubscribe("/imu")
    assert again.destroyed
    again.destroyed = False  # anything left is never taken again
    again.queue.append(b"late")
    assert receiver.take_all() == 0
    receiver.stop()
    assert made["/bad"][0].destroyed and made["/quiet"][0].destroyed
