"""The publisher's time stamp of a serialized message, read straight from its bytes.

A message whose type begins with a ``std_msgs/Header`` carries the time its publisher gave
it (``header.stamp``).  The frequency observer takes a publisher's cadence from these
stamps, so that a receiver's scheduling delays do not read as a rate fault
(docs/observers.md).  The stamp sits at a fixed place, so no deserialization is needed:

- ROS 1: ``uint32 seq``, then ``time stamp`` (``uint32 secs``, ``uint32 nsecs``),
  little-endian: bytes 4-12;
- ROS 2 (CDR): a 4-byte encapsulation header (its second byte 1 for little-endian, 0 for
  big-endian), then ``int32 sec``, ``uint32 nanosec``: bytes 4-12 as well.

A stamp of zero means the publisher did not set one, and reads as none.  Only a header as
the first field counts: headers nested deeper (``tf2_msgs/TFMessage``'s transforms) may come
from several sources in one message.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping
from typing import Any

from rosbags.interfaces import Nodetype

HEADER_TYPES = frozenset({"std_msgs/msg/Header", "roslib/msg/Header"})
_LE = struct.Struct("<II")
_LE_SIGNED = struct.Struct("<iI")
_BE_SIGNED = struct.Struct(">iI")

StampReader = Callable[[bytes], "float | None"]


def has_header(fielddefs: Mapping[str, Any], typename: str) -> bool:
    """Whether ``typename``'s first field is a ``std_msgs/Header`` (``roslib/Header`` in old
    ROS 1 bags)."""
    definition = fielddefs.get(typename)
    if not definition or not definition[1]:
        return False
    _, (nodetype, detail) = definition[1][0]
    return nodetype == Nodetype.NAME and detail in HEADER_TYPES


def stamp_reader(fielddefs: Mapping[str, Any], typename: str, *, cdr: bool) -> StampReader | None:
    """A reader of the header stamp (seconds, None when zero or unreadable) of messages of
    ``typename``; None when the type has no header first."""
    if not has_header(fielddefs, typename):
        return None
    return cdr_stamp if cdr else ros1_stamp


def ros1_stamp(raw: bytes) -> float | None:
    if len(raw) < 12:
        return None
    secs, nsecs = _LE.unpack_from(raw, 4)
    return _seconds(secs, nsecs)


def cdr_stamp(raw: bytes) -> float | None:
    if len(raw) < 12:
        return None
    sec, nanosec = (_LE_SIGNED if raw[1] & 1 else _BE_SIGNED).unpack_from(raw, 4)
    return _seconds(sec, nanosec)


def _seconds(sec: int, nsec: int) -> float | None:
    if sec == 0 and nsec == 0:
        return None
    return sec + nsec * 1e-9
