"""The nodes of the ROS 2 relay graph (tests/ros2/rclpy_graph.py), as a robot's rclpy
nodes would be written: each a process of its own, named by ``--ros-args -r __node:=``.

- ``relay INPUT OUTPUT TYPE``: every message of INPUT published again on OUTPUT, its bytes
  untouched (a raw subscription and a raw publish, as ROS 2's topic_tools relay forwards a
  serialized message), spun by rclpy's default executor;
- ``player BAG [N]``: a ROS 1 recording played in a loop at its recorded cadence, each
  message converted once to its ROS 2 type (the ROS 1 header's ``seq`` dropped) and
  published as CDR bytes with its recorded stamps, as ``rosbag play --loop`` does on ROS 1;
  with N, only every N-th message of each topic (a graph at a tenth of the rate).

Both queue 10 messages, reliable, as a node's ``create_publisher(T, topic, 10)`` does.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import sys
import time
from pathlib import Path
from typing import Any

QUEUE = 10


def message_class(kind: str) -> Any:
    """``sensor_msgs/msg/Imu`` -> the rclpy message class."""
    package, _, name = kind.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def relay(argv: list[str]) -> None:
    import rclpy
    from rclpy.executors import ExternalShutdownException

    source, target, kind = argv[:3]
    rclpy.init(args=argv)
    node = rclpy.create_node("relay")
    cls = message_class(kind)
    publisher = node.create_publisher(cls, target, QUEUE)
    node.create_subscription(cls, source, publisher.publish, QUEUE, raw=True)
    with contextlib.suppress(KeyboardInterrupt, ExternalShutdownException):
        rclpy.spin(node)


def _to_ros2(value: Any, types: Any) -> Any:
    """A rosbags ROS 1 message (or field) as the ROS 2 store's: same fields by name."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        cls = types[getattr(value, "__msgtype__")]  # noqa: B009 - a dataclass of rosbags
        return cls(
            **{f.name: _to_ros2(getattr(value, f.name), types) for f in dataclasses.fields(cls)}
        )
    if isinstance(value, list):
        return [_to_ros2(v, types) for v in value]
    return value


def recording(bag: Path, every: int = 1) -> list[tuple[float, str, str, bytes]]:
    """(offset s, topic, ROS 2 type, CDR bytes) of every ``every``-th message of each topic
    of a ROS 1 bag."""
    from rosbags.rosbag1 import Reader
    from rosbags.typesys import Stores, get_typestore

    ros1, ros2 = get_typestore(Stores.ROS1_NOETIC), get_typestore(Stores.ROS2_JAZZY)
    out = []
    seen: dict[str, int] = {}
    with Reader(bag) as reader:
        start = reader.start_time
        for connection, t, raw in reader.messages():
            seen[connection.topic] = seen.get(connection.topic, -1) + 1
            if seen[connection.topic] % every:
                continue
            message = _to_ros2(ros1.deserialize_ros1(raw, connection.msgtype), ros2.types)
            cdr = bytes(ros2.serialize_cdr(message, connection.msgtype))
            topic = "/" + connection.topic.lstrip("/")
            out.append(((t - start) / 1e9, topic, connection.msgtype, cdr))
    return out


def player(argv: list[str]) -> None:
    import rclpy

    every = int(argv[1]) if len(argv) > 1 and not argv[1].startswith("-") else 1
    messages = recording(Path(argv[0]), every)
    rclpy.init(args=argv)
    node = rclpy.create_node("player")
    kinds = {topic: kind for _, topic, kind, _ in messages}
    publishers = {
        topic: node.create_publisher(message_class(kind), topic, QUEUE)
        for topic, kind in kinds.items()
    }
    span = messages[-1][0] + 0.02  # a loop lasts the recording and one gap
    try:
        loop_start = time.monotonic()
        while rclpy.ok():
            for offset, topic, _, cdr in messages:
                delay = loop_start + offset - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                publishers[topic].publish(cdr)
            loop_start += span
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    {"relay": relay, "player": player}[sys.argv[1]](sys.argv[2:])
