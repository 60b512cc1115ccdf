"""What a racc node needs of ROS, written once for both versions: a :class:`Bus` (publish and
receive arrays of statuses and strings, log, know when to stop, seal and check racc's
messages).  ``rac.ros1.common.Ros1Bus`` and ``rac.ros2.common.Session`` provide it over
rospy and rclpy; the nodes' loops (:mod:`rac.runtime.nodes`) and the runtime's tools
(``racc watch``, ``racc confirm``) see ROS only through it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

from rac.runtime.status import Row
from rac.runtime.trust import Gate, Trust


class TextPublisher(Protocol):
    def __call__(self, text: str) -> None: ...

    def listeners(self) -> int:
        """How many subscribers it is connected to now."""
        ...


@dataclass(frozen=True, slots=True)
class Texts:
    """A :class:`TextPublisher` from a transport's send and subscriber count."""

    send: Callable[[str], None]
    count: Callable[[], int]

    def __call__(self, text: str) -> None:
        self.send(text)

    def listeners(self) -> int:
        return self.count()


class Bus(Protocol):
    """One ROS node's connection to the graph, as the racc nodes use it.

    ``trust`` seals what the node publishes for a ``purpose`` and holds the gates its
    subscriptions pass (:mod:`rac.runtime.trust`); a bus without it (a viewer such as
    ``racc watch``) neither seals nor checks."""

    @property
    def name(self) -> str:
        """The node's resolved name, without the leading '/'."""
        ...

    @property
    def ok(self) -> bool:
        """False once the node is asked to stop (Ctrl-C, SIGTERM, ROS shutdown)."""
        ...

    @property
    def trust(self) -> Trust | None: ...

    def log(self, level: int, text: str) -> None:
        """Log at a status level: 0 info, 1 warning, 2 and above error."""
        ...

    def rows_publisher(
        self, topic: str, depth: int, latched: bool = False, purpose: str = ""
    ) -> Callable[[Sequence[Row]], None]:
        """Publish rows as one ``diagnostic_msgs/DiagnosticArray``; ``latched``: the last
        array is kept for subscribers that join later; ``purpose``: sealed for it."""
        ...

    def on_rows(
        self,
        topic: str,
        callback: Callable[[list[Row]], None],
        depth: int,
        latched: bool = False,
        gate: Gate | None = None,
    ) -> None:
        """Call ``callback`` with the rows of each array on ``topic``; ``latched``: also
        receive the array a latched publisher kept; ``gate``: only arrays it admits."""
        ...

    def text_publisher(self, topic: str, depth: int) -> TextPublisher:
        """Publish ``std_msgs/String`` texts on ``topic`` (sealed by the caller)."""
        ...

    def on_text(
        self,
        topic: str,
        callback: Callable[[str, str], None],
        depth: int,
        gate: Gate | None = None,
    ) -> None:
        """Call ``callback(text, sender)`` with each ``std_msgs/String`` on ``topic``
        (``~name``: the node's private topic); with a ``gate``, only the sealed texts it
        admits, without their seal, and their sender (else the sender is "")."""
        ...
