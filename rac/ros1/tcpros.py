"""A lean TCPROS receiver: every observed topic's connections read by one thread.

rospy receives each connection on a thread of its own and turns each message into a Python
object before a callback sees it (``rospy.AnyMsg`` included: an object, a copy of its bytes,
a lock and a queue per message).  At a real robot's size (a hundred topics, thousands of
messages a second) that path alone cost the observer host about 50 µs a message, and a
hundred threads contending for the interpreter.  The observer host needs far less: how many
messages came, when, the header stamp at its fixed place, and the bytes only of the topics
whose fields an observer reads.

So rospy still does everything a subscriber must do with the graph (registration with the
master, ``publisherUpdate``, ``requestTopic``, the connection's handshake, whose header
gives the publisher's ``callerid`` and type), and then hands the connected socket to
:class:`LeanReceiver`: one thread, one ``selectors`` loop over every socket, reading what
the kernel holds in one ``recv`` and splitting it on the length prefixes.  A message is
never deserialized here: per message the receiver reads its length, and, as the topic asks,
the header's ``uint32 seq`` and stamp (``secs``, ``nsecs``: bytes 0-12 of the message) or
a copy of its bytes.  The loop polls every :data:`POLL_S` (5 ms), so that each pass takes
what came on every connection meanwhile: the receive time of a message is known to within
that, which is far below a frequency observer's tolerance (a 2 s window).

The transport is rospy's own :class:`TCPROSTransport`, so rospy's bookkeeping (its
connections of a topic, ``rosnode info``) sees the connection as usual; closing it (rospy
does when the master no longer lists the publisher; the observer host does for a stranger's
connection) takes it out of the loop first.
"""

from __future__ import annotations

import contextlib
import selectors
import struct
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

POLL_S = 0.05  # the loop sleeps this long between passes (messages then come in batches)
CHUNK = 1 << 18  # bytes read per recv at most
_LENGTH = struct.Struct("<I")
_HEADER = struct.Struct("<III")  # seq, stamp secs, stamp nsecs


@dataclass(frozen=True, slots=True)
class Batch:
    """What one pass read on one connection: ``count`` messages, each one's header stamp
    (seconds; None without one or when zero) when the topic is stamped, and each one's bytes
    when the topic keeps them."""

    topic: str
    connection: Any  # the rospy transport: its ``header`` (callerid, type) and endpoint_id
    count: int
    stamps: list[float | None]
    bodies: list[bytes]
    seqs: list[int | None] = field(default_factory=list)  # header.seq, with the stamps


@dataclass(slots=True)
class LeanTopic:
    """How the receiver reads one topic's messages; ``stamped`` and ``keep_bytes`` are
    decided on its first connection (:meth:`LeanReceiver.describe`)."""

    name: str
    stamped: bool = False
    keep_bytes: bool = False
    decided: bool = False


class _Stream:
    __slots__ = ("buffer", "connection", "fd", "topic")

    def __init__(self, topic: LeanTopic, connection: Any, fd: int, leftover: bytes) -> None:
        self.topic = topic
        self.connection = connection
        self.fd = fd  # unregistered by number: rospy may have closed the socket already
        self.buffer = bytearray(leftover)


class LeanReceiver:
    """The receiving thread (module docstring).  ``deliver(batch)`` runs on it, once per
    connection and pass; ``describe(topic, connection)`` once per topic, on its first
    connection, and returns (stamped, keep_bytes) for it."""

    def __init__(
        self,
        deliver: Callable[[Batch], None],
        describe: Callable[[str, Any], tuple[bool, bool]],
        poll_s: float = POLL_S,
    ) -> None:
        self.deliver, self.describe, self.poll_s = deliver, describe, poll_s
        self.topics: dict[str, LeanTopic] = {}
        self._selector = selectors.DefaultSelector()
        self._lock = threading.Lock()
        self._pending: list[tuple[bool, Any]] = []  # (adopt?, connection) for the loop
        self._streams: dict[int, _Stream] = {}  # id(connection) -> stream
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.messages = 0  # received so far (for the host's cost report)
        self.cpu_s = 0.0  # the receiving thread's CPU time so far: the per-message path
        self.errors: list[str] = []  # what failed on a delivery, for the log

    def add_topic(self, name: str) -> None:
        self.topics.setdefault(name, LeanTopic(name))

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="racc-tcpros", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()

    def adopt(self, connection: Any, leftover: bytes) -> None:
        """A connection rospy has made (handshake done): read by the loop from now on."""
        with self._lock:
            self._pending.append((True, (connection, leftover)))

    def drop(self, connection: Any) -> None:
        """Stop reading ``connection`` (it is closed by whoever called)."""
        with self._lock:
            self._pending.append((False, connection))

    @property
    def connections(self) -> int:
        return len(self._streams)

    def _apply_pending(self) -> None:
        with self._lock:
            pending, self._pending = self._pending, []
        for adopt, item in pending:
            if adopt:
                connection, leftover = item
                self._add(connection, leftover)
            else:
                self._remove(item)

    def _add(self, connection: Any, leftover: bytes) -> None:
        sock = connection.socket
        topic = self.topics.get(connection.name)
        if sock is None or topic is None or connection.done:
            return
        if not topic.decided:
            topic.stamped, topic.keep_bytes = self.describe(topic.name, connection)
            topic.decided = True
        sock.setblocking(False)
        stream = _Stream(topic, connection, sock.fileno(), leftover)
        self._streams[id(connection)] = stream
        self._selector.register(stream.fd, selectors.EVENT_READ, stream)

    def _remove(self, connection: Any) -> None:
        stream = self._streams.pop(id(connection), None)
        if stream is not None:
            with contextlib.suppress(KeyError, ValueError, OSError):
                self._selector.unregister(stream.fd)

    def _run(self) -> None:
        while not self._stop.is_set():
            self.cpu_s = time.thread_time()
            self._apply_pending()
            if not self._streams:
                time.sleep(self.poll_s)
                continue
            try:
                ready = self._selector.select(timeout=0.5)
            except OSError:  # a socket closed under the selector: take it out and go on
                self._prune()
                continue
            self._apply_pending()  # a connection dropped while the loop waited is not read
            streams = self._streams
            for key, _ in ready:
                if id(key.data.connection) in streams:
                    self._read(key.data)
            time.sleep(self.poll_s)

    def _prune(self) -> None:
        for stream in list(self._streams.values()):
            sock = stream.connection.socket
            if sock is None or sock.fileno() < 0:
                self._close(stream)

    def _close(self, stream: _Stream) -> None:
        connection = stream.connection
        self._remove(connection)
        with contextlib.suppress(Exception):  # rospy's own close: its bookkeeping, once
            connection.close_now()

    def _read(self, stream: _Stream) -> None:
        sock = stream.connection.socket
        if sock is None:
            self._close(stream)
            return
        try:
            data: bytes | bytearray = sock.recv(CHUNK)
        except BlockingIOError:
            return
        except OSError:
            data = b""
        if not data:
            self._close(stream)  # the publisher hung up
            return
        if stream.buffer:
            stream.buffer += data
            data = stream.buffer
        self._split(stream, data)

    def _split(self, stream: _Stream, data: bytes | bytearray) -> None:
        """Take the whole messages of ``data``; what is left waits for the next read."""
        size = len(data)
        topic = stream.topic
        stamped, keep = topic.stamped, topic.keep_bytes
        stamps: list[float | None] = []
        seqs: list[int | None] = []
        bodies: list[bytes] = []
        pos = count = 0
        unpack_length, unpack_header = _LENGTH.unpack_from, _HEADER.unpack_from
        while size - pos >= 4:
            (length,) = unpack_length(data, pos)
            end = pos + 4 + length
            if end > size:
                break
            if stamped:
                if length >= 12:
                    seq, secs, nsecs = unpack_header(data, pos + 4)
                    stamps.append(secs + nsecs * 1e-9 if secs or nsecs else None)
                    seqs.append(seq)
                else:
                    stamps.append(None)
                    seqs.append(None)
            if keep:
                bodies.append(bytes(data[pos + 4 : end]))
            count += 1
            pos = end
        stream.buffer = bytearray(data[pos:]) if pos < size else bytearray()
        if not count:
            return
        self.messages += count
        connection = stream.connection
        connection.stat_num_msg += count
        connection.stat_bytes += pos
        try:
            self.deliver(Batch(topic.name, connection, count, stamps, bodies, seqs))
        except Exception as err:  # one delivery that fails must not stop every topic
            if len(self.errors) < 100:
                self.errors.append(f"{topic.name}: {type(err).__name__}: {err}")


def lean_transport_class(receiver: LeanReceiver) -> type:
    """rospy's TCPROSTransport, made to hand its socket to ``receiver`` once the handshake
    is done (imported here: rospy is heavy and optional)."""
    from rospy.impl.tcpros_base import TCPROSTransport

    class LeanTransport(TCPROSTransport):  # type: ignore[misc]
        def receive_loop(self, msgs_callback: Any) -> None:
            # Called on rospy's connecting thread after the handshake: the bytes read past
            # the handshake header are the first message's.
            buff = self.read_buff
            leftover = buff.getvalue()[: buff.tell()] if buff is not None else b""
            receiver.adopt(self, leftover)

        def close(self) -> None:
            """Out of the receiver's loop first, then rospy's own close."""
            receiver.drop(self)
            self.close_now()

        def close_now(self) -> None:
            super().close()

    return LeanTransport


def install(receiver: LeanReceiver, topics: Iterable[str]) -> None:
    """Make this rospy node's subscriptions of ``topics`` use ``receiver``: a protocol
    handler that makes their connections lean goes before rospy's own TCPROS handler (the
    node's ROS handler asks its handlers in order).  Call after ``rospy.init_node`` and
    before subscribing."""
    import rospy
    from rospy.impl.registration import RegManager, get_registration_listeners
    from rospy.impl.tcpros_pubsub import TCPROSHandler

    for topic in topics:
        receiver.add_topic(topic)
    transport = lean_transport_class(receiver)

    class LeanHandler(TCPROSHandler):  # type: ignore[misc]
        def create_transport(self, resolved_name: str, pub_uri: str, params: Any) -> Any:
            if resolved_name not in receiver.topics:
                return super().create_transport(resolved_name, pub_uri, params)
            return _lean_transport(transport, resolved_name, pub_uri, params)

    handler = LeanHandler()
    managers = [m for m in get_registration_listeners().listeners if isinstance(m, RegManager)]
    for manager in managers:
        handlers = manager.handler.protocol_handlers
        if handlers is not None and not any(isinstance(h, LeanHandler) for h in handlers):
            handlers.insert(0, handler)
    if not managers:
        raise RuntimeError("rospy has no registration manager: call rospy.init_node first")
    receiver.start()
    rospy.on_shutdown(receiver.stop)


def _lean_transport(transport: type, resolved_name: str, pub_uri: str, params: Any) -> Any:
    """rospy's TCPROSHandler.create_transport, with the lean transport (same checks, same
    connecting thread: it connects, shakes hands, then hands the socket over)."""
    import rospy
    from rospy.impl.tcpros_base import TCPROS
    from rospy.impl.tcpros_pubsub import TCPROSSub, robust_connect_subscriber

    if not isinstance(params, list) or len(params) != 3:
        return 0, "ERROR: invalid TCPROS parameters", 0
    if params[0] != TCPROS:
        return 0, f"INTERNAL ERROR: protocol id is not TCPROS: {params[0]}", 0
    _, dest_addr, dest_port = params
    sub = rospy.impl.registration.get_topic_manager().get_subscriber_impl(resolved_name)
    protocol = TCPROSSub(
        resolved_name,
        sub.data_class,
        queue_size=sub.queue_size,
        buff_size=sub.buff_size,
        tcp_nodelay=sub.tcp_nodelay,
    )
    conn = transport(protocol, resolved_name)
    conn.set_endpoint_id(pub_uri)
    thread = threading.Thread(
        name=resolved_name,
        target=robust_connect_subscriber,
        args=(conn, dest_addr, dest_port, pub_uri, sub.receive_callback, resolved_name),
        daemon=True,
    )
    if sub.add_connection(conn):
        thread.start()
        return 1, f"Connected topic[{resolved_name}]. Transport impl[lean]", dest_port
    conn.close()
    return 0, f"ERROR: Race condition failure creating topic subscriber [{resolved_name}]", 0
