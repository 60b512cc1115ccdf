"""What a message costs the observer host on ROS 2: rclpy's raw receive path, measured.

    .venv-ros2/bin/python bench/ros2_receive.py                  # 100 topics, 30 s each way
    .venv-ros2/bin/python bench/ros2_receive.py --topics 50 --seconds 20

A publisher process sends the relay graph's traffic (tests/ros1/relay_graph.py: half the
topics ``sensor_msgs/Imu`` at 50 Hz, half ``sensor_msgs/JointState`` with 42 joints at
100 Hz, with header stamps), and a receiver process subscribes to every topic raw (CDR
bytes, no deserialization, best effort, as racc's host does) and is measured by its own
CPU seconds per message received:

- ``count``: the callback only counts (rclpy's own path: the executor, the take, the
  callback);
- ``host``: the callback is the observer host's (the header stamp read from the bytes, the
  message fed to the frequency observers of a model of these topics);

each with racc's receiving thread (``take``, :mod:`rac.ros2.receive`: raw subscriptions
that no executor waits on, every message taken in batches every 50 ms), with rclpy's
``SingleThreadedExecutor`` and a callback per message (what racc used before) and with its
C++ ``EventsExecutor`` (``rclpy.experimental``, Jazzy), which racc does not use: spun by it
the host hung at start (the ROS 2 hostile test's runtime never came up).  Run with
``ROS_DOMAIN_ID`` of your own and ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def topics(n: int) -> list[tuple[str, str, float]]:
    """(topic, type, rate) of ``n`` topics: the relay graph's two kinds, half each."""
    half = n // 2
    imu = [(f"/imu_{i}", "sensor_msgs/msg/Imu", 50.0) for i in range(1, half + 1)]
    js = [(f"/js_{i}", "sensor_msgs/msg/JointState", 100.0) for i in range(1, n - half + 1)]
    return imu + js


def publish(n: int, seconds: float) -> None:
    import rclpy
    from sensor_msgs.msg import Imu, JointState  # type: ignore[import-not-found]

    rclpy.init()
    node = rclpy.create_node("racc_bench_talker")
    pubs = []
    for topic, kind, rate in topics(n):
        cls = Imu if kind.endswith("Imu") else JointState
        pubs.append((node.create_publisher(cls, topic, 10), cls, 1.0 / rate))
    joints = [f"joint_{k}" for k in range(42)]
    due = [0.0] * len(pubs)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        now = time.monotonic()
        for i, (pub, cls, period) in enumerate(pubs):
            if now < due[i]:
                continue
            due[i] = max(due[i] + period, now)
            msg = cls()
            msg.header.stamp = node.get_clock().now().to_msg()
            if cls is JointState:
                msg.name = joints
                msg.position = [0.1] * 42
                msg.velocity = [0.0] * 42
                msg.effort = [0.0] * 42
            pub.publish(msg)
        time.sleep(0.001)
    rclpy.shutdown()


def receive(n: int, seconds: float, mode: str, executor_kind: str) -> None:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import Imu, JointState

    sys.path.insert(0, str(ROOT))
    from rac.logic import Atom
    from rac.passes.observers import ObserverSpec
    from rac.ros2.common import sensor_qos
    from rac.runtime.host import ObserverHost
    from rac.runtime.values import Readers

    rclpy.init()
    node = rclpy.create_node("racc_bench_listener")
    specs = [
        ObserverSpec(
            "GObs",
            f"{t.strip('/')}_gobs",
            (("topic", t), ("delta", 1 / r), ("mismatch_th", 5)),
            (Atom("ok", (t.strip("/"),)),),
        )
        for t, _, r in topics(n)
    ]
    host = ObserverHost(specs)
    readers = Readers(host.bank.topic_fields(), ros_version=2)
    count = [0]
    taking: list[Callable[[], float]] = [lambda: 0.0]  # the taking thread's CPU seconds

    def _callback(mode: str, topic: str, kind: str) -> Callable[[bytes], None]:
        def counted(raw: bytes) -> None:
            count[0] += 1

        def observed(raw: bytes) -> None:
            count[0] += 1
            values, stamp = readers.read(topic, raw, lambda: (kind, ""))
            host.message(topic, values, stamp)

        return counted if mode == "count" else observed

    if executor_kind == "take":
        # racc's host: raw subscriptions no executor waits on, taken from by one thread.
        from rac.ros2.receive import Batch, PollingReceiver, depth_for, raw_subscription

        kinds = {topic: kind for topic, kind, _ in topics(n)}

        def on_batch(batch: Batch) -> None:
            count[0] += len(batch.raws)
            if mode == "count":
                return
            kind = kinds[batch.topic]
            reader = readers.reader(batch.topic, lambda: (kind, ""))
            stamps = [reader.stamp(raw) for raw in batch.raws] if reader.stamped else []
            host.messages(batch.topic, len(batch.raws), stamps)

        receiver = PollingReceiver(on_batch, raw_subscription(node, sensor_qos))
        for topic, kind, rate in topics(n):
            cls = Imu if kind.endswith("Imu") else JointState
            receiver.subscribe(topic, cls, depth_for(rate))
        receiver.start()
        taking[0] = lambda: receiver.cpu_s
    else:
        for topic, kind, _ in topics(n):
            cls = Imu if kind.endswith("Imu") else JointState
            callback = _callback(mode, topic, kind)
            node.create_subscription(cls, topic, callback, sensor_qos(), raw=True)
    if executor_kind == "events":
        from rclpy.experimental import EventsExecutor

        executor: object = EventsExecutor()
    else:
        executor = SingleThreadedExecutor()
    executor.add_node(node)  # type: ignore[attr-defined]
    spin = executor.spin_once  # type: ignore[attr-defined]
    warm = time.monotonic() + 5.0
    while time.monotonic() < warm:
        spin(timeout_sec=0.1)
    c0, r0, w0 = count[0], resource.getrusage(resource.RUSAGE_SELF), time.monotonic()
    k0 = taking[0]()
    while time.monotonic() < w0 + seconds:
        spin(timeout_sec=0.1)
    c1, r1, w1 = count[0], resource.getrusage(resource.RUSAGE_SELF), time.monotonic()
    k1 = taking[0]()
    got = c1 - c0
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    print(
        f"{mode:<6} {executor_kind:<7} {got / (w1 - w0):7.0f} msg/s  {100 * cpu / (w1 - w0):5.1f} %"
        f" of a core  {1e6 * cpu / max(got, 1):6.1f} µs a message  "
        f"(user {1e6 * (r1.ru_utime - r0.ru_utime) / max(got, 1):.1f}, "
        f"system {1e6 * (r1.ru_stime - r0.ru_stime) / max(got, 1):.1f}"
        + (f"; the taking thread {1e6 * (k1 - k0) / max(got, 1):.1f}" if k1 > k0 else "")
        + f")  load {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    os._exit(0)  # rclpy's shutdown with an executor mid-spin can hang


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--topics", type=int, default=100, help="topics (default 100)")
    parser.add_argument(
        "--seconds", type=float, default=30.0, help="measured per case, s (default 30)"
    )
    parser.add_argument("--role", choices=("main", "publish", "receive"), default="main")
    parser.add_argument("--mode", default="count")
    parser.add_argument("--executor", default="single")
    parser.add_argument(
        "--executors",
        default="take,single,events",
        help="the receive paths compared (take: racc's receiving thread; single, events: "
        "rclpy's executors with a callback per message)",
    )
    args = parser.parse_args()
    if args.role == "publish":
        publish(args.topics, args.seconds)
        return
    if args.role == "receive":
        receive(args.topics, args.seconds, args.mode, args.executor)
        return
    me = [sys.executable, __file__, "--topics", str(args.topics)]
    cases = [(m, e) for m in ("count", "host") for e in args.executors.split(",")]
    total = (args.seconds + 8) * len(cases) + 10
    talker = subprocess.Popen([*me, "--role", "publish", "--seconds", str(total)])
    try:
        time.sleep(3.0)
        print(f"{args.topics} topics; the receiver's own CPU per message received")
        for mode, executor in cases:
            subprocess.run(
                [
                    *me,
                    "--role",
                    "receive",
                    "--seconds",
                    str(args.seconds),
                    "--mode",
                    mode,
                    "--executor",
                    executor,
                ],
                timeout=args.seconds + 60,
                check=False,
            )
    finally:
        talker.terminate()
        talker.wait(10)


if __name__ == "__main__":
    main()
