"""The lean TCPROS receiver (rac/ros1/tcpros.py) on socket pairs: messages split on their
length prefixes whatever the reads cut, header stamps read at their place, bytes kept only
when asked, a publisher that hangs up or a connection dropped taken out of the loop.  No
ROS needed: the receiver reads sockets; rospy only hands them over."""

from __future__ import annotations

import socket
import struct
import threading
import time
from collections.abc import Callable
from typing import Any

from rac.ros1.tcpros import Batch, LeanReceiver


class FakeConnection:
    """What the receiver reads of rospy's transport."""

    def __init__(self, name: str, sock: socket.socket) -> None:
        self.name = name
        self.socket: socket.socket | None = sock
        self.done = False
        self.header = {"callerid": "/talker", "type": "sensor_msgs/Imu"}
        self.stat_num_msg = 0
        self.stat_bytes = 0
        self.closed = threading.Event()

    def close_now(self) -> None:
        if self.socket is not None:
            self.socket.close()
        self.socket = None
        self.done = True
        self.closed.set()


def frame(seq: int, secs: int, nsecs: int, tail: bytes = b"payload") -> bytes:
    body = struct.pack("<III", seq, secs, nsecs) + tail
    return struct.pack("<I", len(body)) + body


def receiver(
    stamped: bool = True, keep: bool = False
) -> tuple[LeanReceiver, list[Batch], Callable[[int], bool]]:
    got: list[Batch] = []
    lock = threading.Lock()

    def deliver(batch: Batch) -> None:
        with lock:
            got.append(batch)

    r = LeanReceiver(deliver, lambda topic, connection: (stamped, keep), poll_s=0.005)
    r.add_topic("/imu")

    def wait(count: int) -> bool:
        deadline = time.time() + 5
        while time.time() < deadline:
            with lock:
                if sum(b.count for b in got) >= count:
                    return True
            time.sleep(0.01)
        return False

    return r, got, wait


def pair() -> tuple[socket.socket, FakeConnection]:
    ours, theirs = socket.socketpair()
    return theirs, FakeConnection("/imu", ours)


def test_messages_are_split_on_their_lengths_whatever_the_reads_cut() -> None:
    r, got, wait = receiver()
    publisher, conn = pair()
    first = frame(1, 100, 500_000_000)
    r.adopt(conn, first[:7])  # the handshake's read took part of the first message
    r.start()
    try:
        publisher.sendall(first[7:] + frame(2, 0, 0) + frame(3, 101, 0)[:5])
        time.sleep(0.05)
        publisher.sendall(frame(3, 101, 0)[5:])
        assert wait(3)
    finally:
        r.stop()
    stamps = [s for b in got for s in b.stamps]
    assert stamps == [100.5, None, 101.0]  # a zero stamp is none
    assert [q for b in got for q in b.seqs] == [1, 2, 3]
    assert all(b.bodies == [] for b in got)  # only stamps asked for
    assert conn.stat_num_msg == 3 and r.messages == 3
    assert all(b.connection is conn and b.topic == "/imu" for b in got)


def test_bytes_are_kept_when_the_topic_reads_fields() -> None:
    r, got, wait = receiver(stamped=False, keep=True)
    publisher, conn = pair()
    r.adopt(conn, b"")
    r.start()
    try:
        publisher.sendall(frame(7, 1, 2, b"abc") + frame(8, 1, 3, b""))
        assert wait(2)
    finally:
        r.stop()
    bodies = [x for b in got for x in b.bodies]
    assert bodies == [struct.pack("<III", 7, 1, 2) + b"abc", struct.pack("<III", 8, 1, 3)]
    assert all(b.stamps == [] for b in got)


def test_a_publisher_that_hangs_up_is_closed_and_left() -> None:
    r, _, wait = receiver()
    publisher, conn = pair()
    r.adopt(conn, b"")
    r.start()
    try:
        publisher.sendall(frame(1, 5, 0))
        assert wait(1)
        publisher.close()
        assert conn.closed.wait(5), "the receiver did not close the connection"
        deadline = time.time() + 5
        while r.connections and time.time() < deadline:
            time.sleep(0.01)
        assert r.connections == 0
    finally:
        r.stop()


def test_a_dropped_connection_delivers_nothing_more() -> None:
    r, got, wait = receiver()
    publisher, conn = pair()
    r.adopt(conn, b"")
    r.start()
    try:
        publisher.sendall(frame(1, 5, 0))
        assert wait(1)
        r.drop(conn)
        time.sleep(0.1)
        publisher.sendall(frame(2, 6, 0))
        time.sleep(0.2)
        assert sum(b.count for b in got) == 1
        assert r.connections == 0
    finally:
        r.stop()
        publisher.close()


def test_a_delivery_that_fails_is_kept_for_the_log_and_the_loop_goes_on() -> None:
    calls: list[Any] = []

    def deliver(batch: Batch) -> None:
        calls.append(batch)
        if len(calls) == 1:
            raise ValueError("bad")

    r = LeanReceiver(deliver, lambda topic, connection: (True, False), poll_s=0.005)
    r.add_topic("/imu")
    publisher, conn = pair()
    r.adopt(conn, b"")
    r.start()
    try:
        publisher.sendall(frame(1, 5, 0))
        time.sleep(0.1)
        publisher.sendall(frame(2, 6, 0))
        deadline = time.time() + 5
        while len(calls) < 2 and time.time() < deadline:
            time.sleep(0.01)
    finally:
        r.stop()
        publisher.close()
    assert len(calls) == 2
    assert r.errors == ["/imu: ValueError: bad"]
