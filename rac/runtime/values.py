"""The values observers read from raw messages, for any runtime that receives bytes.

A ROS 1 subscription delivers serialized bytes with the connection's type name and message
definition, a ROS 2 raw subscription CDR bytes of a type named in the graph; this module
deserializes them with rosbags (ROS 1: no message package has to be installed, custom
types included; ROS 2: the types rosbags knows, standard ones), reads the fields the
observers asked for with the same layout and extractor ``racc learn`` uses on a recording
(``yaw``, ``pitch`` and ``roll`` derived from a quaternion), and unwraps yaw and roll into
continuous signals as the learner does, incrementally.  Only topics whose fields some
observer reads are deserialized at all; of the others only the header stamp is read
(:mod:`rac.learn.stamps`, a fixed place in the bytes), for the frequency observer.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Mapping

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from rac.learn.fields import FieldSelector, layout_of
from rac.learn.fields import extractor as field_extractor
from rac.learn.stamps import StampReader, stamp_reader

WRAPPING = frozenset({"yaw", "roll"})
TAU = 2 * math.pi


def store_type(ros_type: str) -> str:
    """``sensor_msgs/Imu`` -> ``sensor_msgs/msg/Imu`` (a typestore's spelling)."""
    if "/msg/" in ros_type:
        return ros_type
    package, _, name = ros_type.rpartition("/")
    return f"{package}/msg/{name}"


class Decoders:
    """One typestore for a process; a :class:`TopicValues` per subscribed topic."""

    def __init__(self, ros_version: int = 1) -> None:
        self.ros_version = ros_version
        self.store: Typestore = get_typestore(
            Stores.ROS1_NOETIC if ros_version == 1 else Stores.ROS2_HUMBLE
        )

    def register(self, ros_type: str, definition: str) -> str:
        """Make ``ros_type`` known from its ROS 1 message definition; its typestore name."""
        name = store_type(ros_type)
        if name not in self.store.fielddefs and definition.strip():
            self.store.register(get_types_from_msg(definition, name))
        return name

    def for_topic(
        self, topic: str, fields: frozenset[str], ros_type: str, definition: str
    ) -> TopicValues:
        try:
            name = self.register(ros_type, definition)
        except Exception:  # a definition rosbags cannot parse: arrival times only
            return TopicValues(topic, (), None)
        if name not in self.store.fielddefs:
            return TopicValues(topic, (), None)
        stamp = stamp_reader(self.store.fielddefs, name, cdr=self.ros_version != 1)
        if not fields:
            return TopicValues(topic, (), None, stamp)
        selector = FieldSelector(declared={topic: fields})
        layout = layout_of(self.store.fielddefs, name, topic, selector)
        extract = field_extractor(layout)
        deserialize = (
            self.store.deserialize_ros1 if self.ros_version == 1 else self.store.deserialize_cdr
        )

        def read(raw: bytes) -> tuple[float, ...]:
            return extract(deserialize(raw, name))

        return TopicValues(topic, layout.fields, read, stamp)


class TopicValues:
    """Values of one topic's messages: field -> value, yaw and roll kept continuous; and
    the header stamp where the type has one."""

    def __init__(
        self,
        topic: str,
        fields: tuple[str, ...],
        read: Callable[[bytes], tuple[float, ...]] | None,
        stamp: StampReader | None = None,
    ) -> None:
        self.topic = topic
        self.fields = fields
        self._read = read
        self._stamp = stamp
        self._wrap = tuple(f in WRAPPING for f in fields)
        self._last: list[float] = [math.nan] * len(fields)
        self._turns: list[float] = [0.0] * len(fields)

    def values(self, raw: bytes) -> Mapping[str, float]:
        if self._read is None:
            return {}
        try:
            read = self._read(raw)
        except Exception:  # a message that does not match its definition: no values
            return {}
        out: dict[str, float] = {}
        for i, (field, value) in enumerate(zip(self.fields, read, strict=True)):
            if self._wrap[i] and math.isfinite(value):
                last = self._last[i]
                if math.isfinite(last):
                    jump = value - last
                    if jump > math.pi:
                        self._turns[i] -= TAU
                    elif jump < -math.pi:
                        self._turns[i] += TAU
                self._last[i] = value
                value += self._turns[i]
            out[field] = value
        return out

    @property
    def stamped(self) -> bool:
        """Whether the type begins with a header, whose stamp is then at its fixed place."""
        return self._stamp is not None

    @property
    def reads_fields(self) -> bool:
        """Whether some observer reads fields of these messages (their bytes are needed)."""
        return self._read is not None

    def stamp(self, raw: bytes) -> float | None:
        """The header stamp in seconds; None without a header, or when it is zero."""
        return None if self._stamp is None else self._stamp(raw)


class Readers:
    """A :class:`TopicValues` per topic, made on its first message (thread-safe): a
    transport calls :meth:`values` from any callback thread with the raw bytes and, only
    the first time, the topic's type and definition (``describe``)."""

    def __init__(self, fields: Mapping[str, frozenset[str]], ros_version: int = 1) -> None:
        self.fields = dict(fields)
        self.decoders = Decoders(ros_version)
        self._readers: dict[str, TopicValues] = {}
        self._lock = threading.Lock()

    def values(
        self, topic: str, raw: bytes, describe: Callable[[], tuple[str, str]]
    ) -> Mapping[str, float]:
        return self._reader(topic, describe).values(raw)

    def read(
        self, topic: str, raw: bytes, describe: Callable[[], tuple[str, str]]
    ) -> tuple[Mapping[str, float], float | None]:
        """The values and the header stamp (None: none) of one message."""
        reader = self._reader(topic, describe)
        return reader.values(raw), reader.stamp(raw)

    def reader(self, topic: str, describe: Callable[[], tuple[str, str]]) -> TopicValues:
        """The topic's :class:`TopicValues`, made from ``describe()`` on first use."""
        return self._reader(topic, describe)

    def _reader(self, topic: str, describe: Callable[[], tuple[str, str]]) -> TopicValues:
        reader = self._readers.get(topic)
        if reader is None:
            with self._lock:
                reader = self._readers.get(topic)
                if reader is None:
                    ros_type, definition = describe()
                    fields = self.fields.get(topic, frozenset())
                    reader = self.decoders.for_topic(topic, fields, ros_type, definition)
                    self._readers[topic] = reader
        return reader
