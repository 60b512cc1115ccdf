"""Whose messages count: only the model's publishers of a topic, of its declared type.

Anyone on a ROS graph can publish on any topic.  A stranger's flood on ``/imu_data`` would
read as ``imu_node`` publishing too fast, a ``LaserScan`` on ``/pose`` as the base driver
gone wrong, and racc would restart healthy nodes for them.  The observer host therefore
feeds its observers only from the publishers ``observers.yaml`` names for each topic
(``topics``: the model's publishers and declared type, :class:`TopicSource`); whatever
else arrives is reported once and ignored, never a fault of a modelled node.  How a
transport tells who sent a message is its own (ROS 1: the connection's ``callerid``, held
against the master's record of that node; ROS 2: the graph's publishers of the topic);
the rule is this module's.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from rac.passes.observers import ObserverSpec, TopicSource


def type_name(ros_type: str) -> str:
    """``sensor_msgs/msg/Imu`` and ``sensor_msgs/Imu`` alike: ``sensor_msgs/Imu``."""
    return ros_type.strip().replace("/msg/", "/")


def node_name(name: str) -> str:
    """A node's name as the model writes it: no leading or trailing '/'."""
    return name.strip().strip("/")


class SourceCheck:
    """The model's publishers and type of each observed topic; ``None`` sources (an
    ``observers.yaml`` of an older racc) admit everything."""

    def __init__(self, sources: Mapping[str, TopicSource] | None) -> None:
        self.known = sources is not None
        self._types = {t: type_name(s.msg_type) for t, s in (sources or {}).items() if s.msg_type}
        self._publishers = {
            t: frozenset(node_name(p) for p in s.publishers)
            for t, s in (sources or {}).items()
            if s.publishers
        }

    def declared_type(self, topic: str) -> str | None:
        return self._types.get(topic)

    def wrong_type(self, topic: str, msg_type: str) -> str | None:
        """Why a message of ``msg_type`` on ``topic`` does not count (None: it may)."""
        declared = self._types.get(topic)
        if declared is None or not msg_type or type_name(msg_type) == declared:
            return None
        return f"of type {type_name(msg_type)}, but the model declares {declared}"

    def stranger(self, topic: str, publisher: str) -> str | None:
        """Why a message ``publisher`` sent on ``topic`` does not count (None: it may)."""
        publishers = self._publishers.get(topic)
        if publishers is None or node_name(publisher) in publishers:
            return None
        shown = ", ".join(sorted(publishers))
        return f"not a publisher of {topic} in the model (that is {shown})"

    def reason(self, topic: str, publisher: str, msg_type: str) -> str | None:
        return self.wrong_type(topic, msg_type) or self.stranger(topic, publisher)


def device_reporters(specs: Iterable[ObserverSpec]) -> dict[str, frozenset[str]]:
    """Device -> the nodes the model has report it on ``/diagnostics`` (a DObs's ``node``
    parameter, comma-separated)."""
    out: dict[str, set[str]] = {}
    for spec in specs:
        if spec.kind != "DObs":
            continue
        params = dict(spec.params)
        device, nodes = str(params.get("device", "")), str(params.get("node", ""))
        if device:
            out.setdefault(device, set()).update(node_name(n) for n in nodes.split(",") if n)
    return {d: frozenset(n) for d, n in out.items()}
