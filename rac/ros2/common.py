"""What the rclpy nodes share: importing ROS 2, a node with its executor, statuses, types
and the processes of nodes.

Nothing here decides anything about diagnosis or repair; it moves data between rclpy and
the engines of :mod:`rac.runtime`.
"""

from __future__ import annotations

import importlib
import os
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import psutil

from rac.errors import Diagnostic, RacError
from rac.ros2.args import ROS_ARGS
from rac.runtime.bus import Texts
from rac.runtime.placement import Found, prove_by_cmdline
from rac.runtime.procs import ProcessTable, index_by_node, innermost, node_key
from rac.runtime.status import Row, rows_from_array
from rac.runtime.trust import Gate, Trust, guard_rows, guard_text

HINT = (
    "source a ROS 2 installation (Humble or Jazzy: 'source /opt/ros/jazzy/setup.bash'), or "
    "pip install 'ros-rclpy[fastrtps]' and the ros-*-msgs wheels into racc's venv "
    "(see 'On a ROS 2 robot' in the README)"
)


PROFILES_V2 = "FASTRTPS_DEFAULT_PROFILES_FILE"  # what Fast DDS 2 (Humble, Jazzy) reads
PROFILES_V3 = "FASTDDS_DEFAULT_PROFILES_FILE"  # what Fast DDS 3 reads; it warns about the other


def fastdds_major() -> int | None:
    """The major version of the Fast DDS this Python's rclpy uses, when it can be told: the
    PyPI wheels' metadata, else the ROS distribution (Humble, Iron, Jazzy: 2)."""
    import importlib.metadata

    for dist, major in (("ros-fastdds", 3), ("ros-fastrtps", None)):
        try:
            version = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            continue
        return major or int(version.split(".")[0])
    distro = os.environ.get("ROS_DISTRO", "")
    return 2 if distro in ("humble", "iron", "jazzy") else None


def align_fastdds_profiles(env: dict[str, str] | Any, major: int | None) -> None:
    """One profiles file named either way reaches the Fast DDS at hand under the name it
    reads: FASTDDS_DEFAULT_PROFILES_FILE (the current name) works with Fast DDS 2 too, and
    FASTRTPS_DEFAULT_PROFILES_FILE does not draw Fast DDS 3's deprecation warning."""
    profile = env.get(PROFILES_V3) or env.get(PROFILES_V2)
    if not profile or major is None:
        return
    if major >= 3:
        env[PROFILES_V3] = profile
        env.pop(PROFILES_V2, None)
    else:
        env[PROFILES_V2] = profile


def require_rclpy() -> Any:
    """rclpy, or RAC116 saying how to get it; the Fast DDS profile variable aligned first
    (:func:`align_fastdds_profiles`), for this process and those it starts."""
    align_fastdds_profiles(os.environ, fastdds_major())
    try:
        import rclpy
    except ImportError as err:
        raise RacError(
            [Diagnostic("RAC116", f"ROS 2 is not available to this Python: {err}", hint=HINT)]
        ) from None
    return rclpy


class Session:
    """One rclpy node spun by an executor thread; the caller's loop runs while ``ok``."""

    def __init__(
        self,
        name: str,
        ros_args: Sequence[str] | None = None,
        key: bytes | None = None,
        role: str = "",
        seal_as: str = "",
    ) -> None:
        ros_args = ROS_ARGS if ros_args is None else ros_args
        rclpy = require_rclpy()
        from rclpy.executors import SingleThreadedExecutor

        self.rclpy = rclpy
        rclpy.init(args=["racc", *ros_args])  # SIGINT and SIGTERM end the context
        self.context = rclpy.get_default_context()
        self.node = rclpy.create_node(name)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        sender = seal_as or self.name
        self._trust = Trust(key, role, sender, self.log) if key is not None else None
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception as err:  # after Ctrl-C: the context is down, the loop sees ``ok``
            if self.context.ok():
                self.node.get_logger().error(f"racc: a callback failed: {err!r}")
                self.context.try_shutdown()

    @property
    def ok(self) -> bool:
        return bool(self.context.ok())

    @property
    def name(self) -> str:
        return str(self.node.get_fully_qualified_name()).lstrip("/")

    @property
    def trust(self) -> Trust | None:
        return self._trust

    def rows_publisher(
        self, topic: str, depth: int, latched: bool = False, purpose: str = ""
    ) -> Callable[[Sequence[Row]], None]:
        """:class:`rac.runtime.bus.Bus`'s publisher of status arrays, reliable."""
        from diagnostic_msgs.msg import DiagnosticArray

        pub = self.node.create_publisher(DiagnosticArray, topic, reliable(depth, latched))
        trust = self._trust if purpose else None

        def publish(rows: Sequence[Row]) -> None:
            seal = trust.seal_rows(purpose, rows) if trust is not None else ""
            pub.publish(to_array(self, rows, seal))

        return publish

    def on_rows(
        self,
        topic: str,
        callback: Callable[[list[Row]], None],
        depth: int,
        latched: bool = False,
        gate: Gate | None = None,
    ) -> None:
        """A reliable subscription; ``latched`` (transient local) also receives the array
        a latched publisher kept."""
        from diagnostic_msgs.msg import DiagnosticArray

        guarded = guard_rows(self._trust, topic, gate, callback)

        def receive(array: Any) -> None:
            guarded(rows_from_array(array), array.header.frame_id)

        self.node.create_subscription(DiagnosticArray, topic, receive, reliable(depth, latched))

    def text_publisher(self, topic: str, depth: int) -> Texts:
        from std_msgs.msg import String

        pub = self.node.create_publisher(String, topic, reliable(depth))
        return Texts(lambda text: pub.publish(String(data=text)), pub.get_subscription_count)

    def on_text(
        self,
        topic: str,
        callback: Callable[[str, str], None],
        depth: int,
        gate: Gate | None = None,
    ) -> None:
        """``~name`` is the node's private topic, ``~/name`` in ROS 2's spelling."""
        from std_msgs.msg import String

        if topic.startswith("~") and not topic.startswith("~/"):
            topic = "~/" + topic[1:]
        shown = str(self.node.resolve_topic_name(topic))  # ~/confirm: /racc_repairer/confirm
        guarded = guard_text(self._trust, shown, gate, callback)
        self.node.create_subscription(String, topic, lambda msg: guarded(msg.data), reliable(depth))

    def log(self, level: int, text: str) -> None:
        # rclpy's logger ties a severity to each call site: one line per level.
        logger = self.node.get_logger()
        if level >= 2:
            logger.error(text)
        elif level == 1:
            logger.warning(text)
        else:
            logger.info(text)

    def close(self) -> None:
        # The spin thread must end before the process does (else the C++ side aborts).
        self._shutdown()
        self.executor.shutdown(timeout_sec=1.0)
        self._thread.join(2.0)
        self.node.destroy_node()
        self._shutdown()

    def _shutdown(self) -> None:
        """Shut the context down unless rclpy's signal handler did it meanwhile: between
        ``ok()`` and ``try_shutdown()`` a Ctrl-C can shut it down, and rclpy then raises
        RCLError ("rcl_shutdown already called"), a traceback at every node's stop."""
        try:
            if self.context.ok():
                self.context.try_shutdown()
        except Exception:
            if self.context.ok():
                raise


def reliable(depth: int = 10, latched: bool = False) -> Any:
    """Reliable QoS; ``latched``: the last message kept for late subscribers, as ROS 1's
    latch (transient local durability)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    durability = DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE, durability=durability)


def sensor_qos(depth: int = 50) -> Any:
    """Best effort: it matches reliable and best-effort publishers (sensor drivers often
    publish best effort; a reliable subscriber would not receive them)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        depth=depth,
        reliability=ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.VOLATILE,
    )


def message_class(ros_type: str) -> Any | None:
    """The generated class of ``pkg/msg/Name`` (None: its package is not importable)."""
    package, _, name = ros_type.replace("/msg/", "/").partition("/")
    try:
        return getattr(importlib.import_module(f"{package}.msg"), name, None)
    except ImportError:
        return None


# -- diagnostic statuses ---------------------------------------------------------------------


def to_array(session: Session, rows: Iterable[Row], frame_id: str = "") -> Any:
    """A ``DiagnosticArray`` of the rows; ``frame_id`` carries a racc seal."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

    array = DiagnosticArray()
    array.header.stamp = session.node.get_clock().now().to_msg()
    array.header.frame_id = frame_id
    array.status = [
        DiagnosticStatus(
            level=bytes([r.level]),
            name=r.name,
            message=r.message,
            hardware_id=r.hardware_id,
            values=[KeyValue(key=k, value=v) for k, v in r.values],
        )
        for r in rows
    ]
    return array


# -- nodes and their processes -----------------------------------------------------------------


def graph_nodes(session: Session) -> set[str]:
    """Every node the graph shows, as "name" or "ns/name"."""
    return {
        f"{ns.strip('/')}/{n}".lstrip("/") for n, ns in session.node.get_node_names_and_namespaces()
    }


class PidResolver:
    """``resolve(node)`` for :class:`rac.runtime.procs.ProcessProbe` on ROS 2.

    A node's pid is that of the innermost local process whose command line says
    ``__node:=NAME``, when it is of this PID namespace.  A node the graph shows without
    such a process is on another machine, or in a container (its process is in another
    PID namespace): it is watched through the graph alone, unless it was seen here
    before: DDS keeps a crashed node in the graph until its lease runs out (seconds), so
    a node whose local process has gone is not running until a new process with its
    name appears.
    """

    def __init__(
        self, graph: Callable[[], set[str]], table_s: float = 1.0, missing_s: float = 0.25
    ) -> None:
        self.graph = graph
        self.local: set[str] = set()
        # One scan of the process table serves every node for table_s (each running node
        # is resolved again every second), and a node without a process in it for
        # missing_s: a node (re)started since is found that soon.
        self.table_s, self.missing_s = table_s, missing_s
        self._table = ProcessTable()
        self._index: dict[tuple[str, str], list[Any]] = {}
        self._scanned = float("-inf")

    def __call__(self, node: str) -> Found | None:
        now = time.monotonic()
        key = node_key(node)
        age = now - self._scanned
        procs = self._running(key)
        if age >= self.table_s or (age >= self.missing_s and not procs):
            self._index, self._scanned = index_by_node(self._table.scan()), now
            procs = self._running(key)
        proc = innermost(procs)
        found = prove_by_cmdline(int(proc.pid)) if proc is not None else None
        if found is not None and found.pid is not None:
            self.local.add(node)
            return found
        if node in self.local:
            return None
        if node.strip("/") not in self.graph():
            return None
        return found or Found(None, "in the graph without a process here: another machine")

    def _running(self, key: tuple[str, str]) -> list[Any]:
        """The node's processes in the table that still run; the others leave it (a pid of
        theirs, if reused, is read again)."""
        procs = self._index.get(key, [])
        for gone in [p for p in procs if not _alive(p)]:
            procs.remove(gone)
            self._table.forget(gone)
        return procs


def _alive(proc: Any) -> bool:
    """A process of the table still runs (the table may be a second old)."""
    try:
        return bool(proc.is_running()) and proc.status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False
