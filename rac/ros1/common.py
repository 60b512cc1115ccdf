"""What the rospy nodes share: importing ROS, the master, statuses and raw messages.

Nothing here decides anything about diagnosis or repair; it moves data between rospy and
the engines of :mod:`rac.runtime`.
"""

from __future__ import annotations

import os
import socket
import threading
import time
import xmlrpc.client
from collections.abc import Callable, Iterable, Sequence
from typing import Any
from urllib.parse import urlparse

from rac.errors import Diagnostic, RacError
from rac.runtime.bus import Texts
from rac.runtime.placement import Found, prove_ros1, silent_ros1
from rac.runtime.procs import UNANSWERED
from rac.runtime.status import Row, rows_from_array
from rac.runtime.trust import Gate, Trust, guard_rows, guard_text

CALLER = "/racc"
XMLRPC_TIMEOUT_S = 0.5
VENV_HINT = (
    "install ROS 1's Python packages (Debian/Ubuntu: apt-get install python3-rospy "
    "python3-roslaunch python3-rosbag python3-diagnostic-msgs ...) and run racc from a venv "
    "made with '/usr/bin/python3 -m venv --system-site-packages' (see docs/runtime.md)"
)


def require_ros() -> Any:
    """rospy, or RAC057 saying how to get it."""
    try:
        import rospy
    except ImportError as err:
        raise RacError(
            [Diagnostic("RAC057", f"ROS 1 is not available to this Python: {err}", hint=VENV_HINT)]
        ) from None
    return rospy


def master_uri() -> str:
    return os.environ.get("ROS_MASTER_URI", "http://localhost:11311")


def check_master() -> None:
    """RAC058 when no master answers at ROS_MASTER_URI (RAC057 without ROS 1 at all)."""
    require_ros()  # rosgraph comes with rospy: without them this is RAC057, not a crash
    import rosgraph

    if not rosgraph.is_master_online(master_uri()):
        raise RacError(
            [
                Diagnostic(
                    "RAC058",
                    f"no ROS master at {master_uri()}",
                    hint="start one with 'roscore', or set ROS_MASTER_URI",
                )
            ]
        )


class _TimeoutTransport(xmlrpc.client.Transport):
    def __init__(self, timeout: float) -> None:
        super().__init__()
        self._timeout = timeout

    def make_connection(self, host: Any) -> Any:
        conn = super().make_connection(host)
        conn.timeout = self._timeout
        return conn


def proxy(uri: str, timeout: float = XMLRPC_TIMEOUT_S) -> Any:
    """An XML-RPC proxy whose calls give up after ``timeout`` (answers are untyped)."""
    return xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout))


def _local_hosts() -> frozenset[str]:
    names = {"localhost", "127.0.0.1", "::1", socket.gethostname(), socket.getfqdn()}
    names.update(os.environ.get(k, "") for k in ("ROS_IP", "ROS_HOSTNAME"))
    return frozenset(n for n in names if n)


LOCAL_HOSTS = _local_hosts()


def node_uri(node: str) -> str | None:
    """The XML-RPC URI the master has for ``node`` (no leading '/' needed)."""
    code, _, uri = proxy(master_uri()).lookupNode(CALLER, "/" + node.lstrip("/"))
    return str(uri) if code == 1 else None


def node_hosts(nodes: Iterable[str]) -> dict[str, str]:
    """The host of each node's XML-RPC URI, as the master has it (for ``racc record``'s
    graph: where each node runs)."""
    out = {}
    for node in nodes:
        try:
            uri = node_uri(node)
        except (OSError, xmlrpc.client.Error):
            continue
        host = urlparse(uri).hostname if uri else None
        if host:
            out[node] = host
    return out


def is_local_host(host: str) -> bool:
    return host in LOCAL_HOSTS or host.startswith("127.")


def resolve_pid(node: str) -> Found | None:
    """The node as the master and its own XML-RPC server show it: None when it is not
    there (unregistered, or its server does not answer getPid); else the pid it answered
    when that process is proven to be the node's (:func:`rac.runtime.placement.prove_ros1`),
    or no pid (another machine, another PID namespace: watched through the master)."""
    found = node_liveness(node)
    return None if isinstance(found, int) else found


def node_liveness(node: str) -> Found | int | None:
    """:func:`resolve_pid` for the observer host, which tells a server that refuses the
    connection or denies the node (it is gone) from one that does not answer within
    ``XMLRPC_TIMEOUT_S`` (a node busy on a loaded machine, or frozen): that one's local
    process is found without it (:func:`rac.runtime.placement.silent_ros1`), else it is
    ``UNANSWERED``."""
    uri: str | None = None
    try:
        uri = node_uri(node)
        if uri is None:
            return None
        code, _, pid = proxy(uri).getPid(CALLER)
    except TimeoutError:
        return _silent(node, uri)
    except (OSError, xmlrpc.client.Error):
        return None
    if code != 1:
        return None
    parsed = urlparse(uri)
    host = parsed.hostname or ""
    if not is_local_host(host):
        return Found(None, f"its XML-RPC server is on {host}, another machine")
    return prove_ros1(node, int(pid), parsed.port)


def _silent(node: str, uri: str | None) -> Found | int:
    """A node that did not answer in time: its local process by the port of ``uri`` (or by
    its command line, ``uri`` unknown: the master did not answer), else ``UNANSWERED``."""
    parsed = urlparse(uri) if uri else None
    if parsed is not None and not is_local_host(parsed.hostname or ""):
        return UNANSWERED  # on another machine: nothing here to look at
    found = silent_ros1(node, parsed.port if parsed is not None else None)
    return found if found is not None else UNANSWERED


def system_state() -> tuple[list[Any], list[Any], list[Any]]:
    """The master's getSystemState: (publishers, subscribers, services)."""
    code, message, state = proxy(master_uri(), 2.0).getSystemState(CALLER)
    if code != 1:
        raise RacError([Diagnostic("RAC058", f"the master refused getSystemState: {message}")])
    return state[0], state[1], state[2]


def topic_types() -> dict[str, str]:
    code, _, pairs = proxy(master_uri(), 2.0).getTopicTypes(CALLER)
    return {str(t): str(ty) for t, ty in pairs} if code == 1 else {}


def log_to_ros(rospy: Any) -> Any:
    """``log(level, text)`` for the engines: rospy's log at the status level."""

    def log(level: int, text: str) -> None:
        (rospy.logerr if level >= 2 else rospy.logwarn if level == 1 else rospy.loginfo)(text)

    return log


class Ros1Bus:
    """:class:`rac.runtime.bus.Bus` over rospy: this process's node, started here.

    With a ``key`` and a ``role`` it seals and checks racc's messages
    (:class:`rac.runtime.trust.Trust`), as its node name or as ``seal_as`` (an operator)."""

    def __init__(
        self, name: str, key: bytes | None = None, role: str = "", seal_as: str = ""
    ) -> None:
        self.rospy = require_ros()
        self.rospy.init_node(name)
        self._log = log_to_ros(self.rospy)
        sender = seal_as or self.name
        self._trust = Trust(key, role, sender, self.log) if key is not None else None
        if key is not None:  # racc's own nodes; a tool (racc watch) lives shorter
            MasterRegistration(self).start()

    @property
    def name(self) -> str:
        return str(self.rospy.get_name()).lstrip("/")

    @property
    def ok(self) -> bool:
        return not self.rospy.is_shutdown()

    @property
    def trust(self) -> Trust | None:
        return self._trust

    def log(self, level: int, text: str) -> None:
        self._log(level, text)

    def rows_publisher(
        self, topic: str, depth: int, latched: bool = False, purpose: str = ""
    ) -> Callable[[Sequence[Row]], None]:
        from diagnostic_msgs.msg import DiagnosticArray

        pub = self.rospy.Publisher(topic, DiagnosticArray, queue_size=depth, latch=latched)
        trust = self._trust if purpose else None

        def publish(rows: Sequence[Row]) -> None:
            seal = trust.seal_rows(purpose, rows) if trust is not None else ""
            pub.publish(to_array(rows, frame_id=seal))

        return publish

    def on_rows(
        self,
        topic: str,
        callback: Callable[[list[Row]], None],
        depth: int,
        latched: bool = False,
        gate: Gate | None = None,
    ) -> None:
        # A ROS 1 subscriber receives a latched publisher's last message anyway.
        from diagnostic_msgs.msg import DiagnosticArray

        guarded = guard_rows(self._trust, topic, gate, callback)

        def receive(array: Any) -> None:
            guarded(rows_from_array(array), array.header.frame_id)

        self.rospy.Subscriber(topic, DiagnosticArray, receive, queue_size=depth)

    def text_publisher(self, topic: str, depth: int) -> Texts:
        from std_msgs.msg import String

        pub = self.rospy.Publisher(topic, String, queue_size=depth)
        return Texts(lambda text: pub.publish(String(data=text)), pub.get_num_connections)

    def on_text(
        self,
        topic: str,
        callback: Callable[[str, str], None],
        depth: int,
        gate: Gate | None = None,
    ) -> None:
        from std_msgs.msg import String

        shown = str(self.rospy.resolve_name(topic))  # ~confirm: /racc_repairer/confirm
        guarded = guard_text(self._trust, shown, gate, callback)
        self.rospy.Subscriber(topic, String, lambda msg: guarded(msg.data), queue_size=depth)


class MasterRegistration:
    """Keeps this node registered with the ROS master.  rospy registers a node once, at
    start: after the master is restarted it knows none of the node's topics, so no new
    publisher ever reaches it (a node restarted afterwards is never heard again).  Once a
    second this thread asks the master for its pid: when a master answers again after it
    did not, or answers with another pid (it was restarted between two questions), every
    publication, subscription and service of the node is registered again (as rospy's
    registration manager does at start; registering twice changes nothing) and the
    connections follow the master's answer.  Both the loss and the return are logged.

    Asking the master for the node itself would not do: rospy's own logging subscribes a
    parameter of the new master, which then knows the node, but none of its topics."""

    def __init__(self, bus: Ros1Bus, period_s: float = 1.0) -> None:
        self.bus, self.period_s = bus, period_s
        self.master: int | None = None  # the pid of the master the node registered with
        self.lost = False  # a master did not answer since the last registration

    def start(self) -> None:
        threading.Thread(target=self._watch, name="racc-registration", daemon=True).start()

    def _watch(self) -> None:
        rospy = self.bus.rospy
        while not rospy.is_shutdown():
            time.sleep(self.period_s)
            try:
                code, _, pid = proxy(master_uri(), 1.0).getPid(CALLER)
            except (OSError, xmlrpc.client.Error):
                if not self.lost:
                    self.lost = True
                    self.bus.log(
                        2, f"t={time.time():.3f} the ROS master at {master_uri()} does not answer"
                    )
                continue
            if code != 1:
                continue
            pid = int(pid)
            if self.master is None and not self.lost:
                self.master = pid  # the master of the node's start
                continue
            if pid == self.master and not self.lost:
                continue
            self.bus.log(
                1,
                f"t={time.time():.3f} the ROS master at {master_uri()} answers "
                + ("again" if pid == self.master else f"as a new process (pid {pid})")
                + ": registering this node's topics with it again",
            )
            try:
                counts = register_again(str(rospy.get_node_uri() or ""))
            except (OSError, xmlrpc.client.Error) as err:
                self.bus.log(2, f"t={time.time():.3f} registering again failed: {err}; retrying")
                continue
            self.master, self.lost = pid, False
            self.bus.log(
                0,
                f"t={time.time():.3f} registered again with the master: {counts[0]} "
                f"publications, {counts[1]} subscriptions, {counts[2]} services",
            )


def register_again(uri: str) -> tuple[int, int, int]:
    """Register this rospy node's publications, subscriptions and services with the master
    (after it lost them); the subscriptions connect to the publishers the master names."""
    import rospy
    from rospy.impl.registration import (
        RegManager,
        get_registration_listeners,
        get_service_manager,
        get_topic_manager,
    )

    master = proxy(master_uri(), 2.0)
    caller = rospy.get_name()
    topics, services = get_topic_manager(), get_service_manager()
    managers = [m for m in get_registration_listeners().listeners if isinstance(m, RegManager)]
    pubs, subs, srvs = (
        topics.get_publications(),
        topics.get_subscriptions(),
        services.get_services(),
    )
    for topic, kind in pubs:
        master.registerPublisher(caller, topic, kind, uri)
    for topic, kind in subs:
        code, _, publishers = master.registerSubscriber(caller, topic, kind, uri)
        if code == 1:
            for manager in managers:
                manager.publisher_update(topic, publishers)
    for service, service_uri in srvs:
        master.registerService(caller, service, service_uri, uri)
    return len(pubs), len(subs), len(srvs)


# -- diagnostic statuses ---------------------------------------------------------------------


def to_array(rows: Iterable[Row], stamp: Any = None, frame_id: str = "") -> Any:
    """A ``DiagnosticArray`` of the rows; ``frame_id`` carries a racc seal."""
    import rospy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

    array = DiagnosticArray()
    array.header.stamp = stamp if stamp is not None else rospy.Time.now()
    array.header.frame_id = frame_id
    array.status = [
        DiagnosticStatus(
            level=r.level,
            name=r.name,
            message=r.message,
            hardware_id=r.hardware_id,
            values=[KeyValue(key=k, value=v) for k, v in r.values],
        )
        for r in rows
    ]
    return array


# -- raw messages ------------------------------------------------------------------------------

_RAW: dict[tuple[str, str], type] = {}


def raw_class(ros_type: str, md5sum: str, definition: str) -> type:
    """A message class that publishes bytes serialized elsewhere (rosbags), with the type,
    md5sum and definition of ``ros_type`` in the connection header, as a generated class
    would: subscribers, ``rostopic echo`` and ``rosbag record`` see the real type."""
    key = (ros_type, md5sum)
    found = _RAW.get(key)
    if found is not None:
        return found
    import genpy

    class Raw(genpy.Message):  # type: ignore[misc]
        _type = ros_type
        _md5sum = md5sum
        _full_text = definition
        _has_header = False  # rospy must not touch a header: the bytes are final
        __slots__ = ("_buff",)

        def __init__(self, buff: bytes = b"") -> None:
            self._buff = buff

        def serialize(self, buff: Any) -> None:
            buff.write(self._buff)

        def deserialize(self, data: bytes) -> Raw:
            self._buff = data
            return self

    Raw.__name__ = f"Raw_{ros_type.replace('/', '_')}"
    _RAW[key] = Raw
    return Raw


def connection_type(msg: Any) -> tuple[str, str]:
    """(type, message definition) from an AnyMsg's connection header."""
    return header_type(getattr(msg, "_connection_header", None))


def header_type(header: Any) -> tuple[str, str]:
    """(type, message definition) from a connection header."""
    header = header if isinstance(header, dict) else {}
    return str(header.get("type", "")), str(header.get("message_definition", ""))
