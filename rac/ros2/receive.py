"""The observer host's receiving path on ROS 2: raw subscriptions taken from by one thread.

rclpy delivers a subscription's message through its executor: a wait set rebuilt for
every wake-up, the take, then the Python callback; on the 100-topic relay traffic that
costs about 100 µs a message (``bench/ros2_receive.py``).  The observers need no callback
per message: the frequency observers take what a topic received as one batch, as on ROS 1
(:mod:`rac.ros1.tcpros`).  So the host's topic subscriptions are rcl subscriptions that no
executor waits on: every ``poll_s`` one thread takes every message waiting on each of them
(CDR bytes, with no deserialization; a take costs about 4 µs) and hands each topic's
messages over as one :class:`Batch`.  Nothing of rclpy's executor sees them; the node's
other subscriptions, its timers and publishers go on as before.

A subscription keeps the last ``depth`` messages between two passes (best effort, as the
executor's subscriptions did): the depth is sized from the topic's rate in the model, so
that a pass never finds its queue overflowed by the robot's own publishers.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

POLL_S = 0.05  # how often the thread takes what waits on every subscription
MIN_DEPTH = 32
HEADROOM = 4.0  # a queue holds this many passes' worth of a topic's declared rate


@dataclass(slots=True)
class Batch:
    """The messages one pass took from one subscription: each one's CDR bytes."""

    topic: str
    raws: list[bytes] = field(default_factory=list)


def depth_for(rate_hz: float | None, poll_s: float = POLL_S) -> int:
    """The queue a topic published at ``rate_hz`` needs between two passes."""
    if rate_hz is None or not math.isfinite(rate_hz) or rate_hz <= 0:
        return MIN_DEPTH
    return max(MIN_DEPTH, math.ceil(rate_hz * poll_s * HEADROOM))


class _Raw:
    __slots__ = ("handle", "msg_type", "topic")

    def __init__(self, topic: str, handle: Any, msg_type: Any) -> None:
        self.topic, self.handle, self.msg_type = topic, handle, msg_type


class PollingReceiver:
    """Takes every message of its subscriptions every ``poll_s`` on a thread of its own and
    calls ``deliver(batch)`` once per topic that received some.  ``make(topic, msg_type,
    depth)`` creates an rcl subscription (:func:`raw_subscription`); tests give their own."""

    def __init__(
        self,
        deliver: Callable[[Batch], None],
        make: Callable[[str, Any, int], Any],
        poll_s: float = POLL_S,
    ) -> None:
        self.deliver, self.make, self.poll_s = deliver, make, poll_s
        self._subs: dict[str, _Raw] = {}
        self._lock = threading.Lock()  # held by a pass: a subscription is never destroyed mid-take
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.cpu_s = 0.0  # the taking thread's CPU time so far: the per-message path
        self.errors: list[str] = []  # what failed on a delivery, for the log

    def subscribe(self, topic: str, msg_type: Any, depth: int) -> Any:
        """Take ``topic``'s messages from now on (again: a new subscription); its handle,
        whose ``get_publisher_count()`` says how many publishers DDS has matched."""
        handle = self.make(topic, msg_type, depth)
        with self._lock:
            old = self._subs.pop(topic, None)
            self._subs[topic] = _Raw(topic, handle, msg_type)
        if old is not None:
            old.handle.destroy_when_not_in_use()
        return handle

    def unsubscribe(self, topic: str) -> None:
        """No more of ``topic``: its subscription is destroyed, so that DDS delivers none of
        its messages to this process (a stranger's flood costs nothing here)."""
        with self._lock:
            raw = self._subs.pop(topic, None)
        if raw is not None:
            raw.handle.destroy_when_not_in_use()

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="racc-take", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        with self._lock:
            subs, self._subs = list(self._subs.values()), {}
        for raw in subs:
            raw.handle.destroy_when_not_in_use()

    def take_all(self) -> int:
        """One pass: every waiting message of every subscription, delivered per topic; how
        many were taken."""
        taken = 0
        with self._lock:
            batches = []
            for raw in self._subs.values():
                batch = Batch(raw.topic)
                take, kind = raw.handle.take_message, raw.msg_type
                while (got := take(kind, True)) is not None:
                    batch.raws.append(got[0])
                if batch.raws:
                    batches.append(batch)
                    taken += len(batch.raws)
        for batch in batches:
            try:
                self.deliver(batch)
            except Exception as err:  # one topic's failure must not stop the others
                if len(self.errors) < 100:
                    self.errors.append(f"{batch.topic}: {type(err).__name__}: {err}")
        return taken

    def take_errors(self) -> list[str]:
        out, self.errors = self.errors, []
        return out

    def _run(self) -> None:
        while not self._stop.is_set():
            self.cpu_s = time.thread_time()
            try:
                self.take_all()
            except Exception as err:  # a subscription destroyed under the pass: next pass
                if len(self.errors) < 100:
                    self.errors.append(f"take: {type(err).__name__}: {err}")
            self.cpu_s = time.thread_time()
            self._stop.wait(self.poll_s)


def raw_subscription(node: Any, qos: Callable[[int], Any]) -> Callable[[str, Any, int], Any]:
    """``make`` for :class:`PollingReceiver`: an rcl subscription of ``node`` that no
    executor waits on (rclpy's own ``Subscription`` would join the node's wait set)."""
    from rclpy.impl.implementation_singleton import rclpy_implementation
    from rclpy.type_support import check_for_type_support

    def make(topic: str, msg_type: Any, depth: int) -> Any:
        check_for_type_support(msg_type)
        with node.handle:
            return rclpy_implementation.Subscription(
                node.handle, msg_type, topic, qos(depth).get_c_qos_profile()
            )

    return make
