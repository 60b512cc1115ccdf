"""Whose messages count (rac.runtime.sources, the ROS 1 connection judge of
rac.ros1.observe, the host's device check and the bank's suspension): only the model's
publishers of a topic, of its declared type (issue 34)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rac.logic import Atom
from rac.observe import DeviceStatus, Message, ObserverBank
from rac.passes.observers import ObserverSpec, TopicSource
from rac.ros1.observe import Connections
from rac.runtime.host import ObserverHost
from rac.runtime.sources import SourceCheck, device_reporters, type_name
from rac.runtime.status import Row

SOURCES = {
    "/pose": TopicSource("/pose", "nav_msgs/Odometry", ("jaguar_node",)),
    "/free": TopicSource("/free", None, ()),
}
GOBS = ObserverSpec(
    "GObs",
    "pose_gobs",
    (("topic", "/pose"), ("delta", 0.1), ("dev", 0.011)),
    (Atom("ok", ("pose",)),),
)
DOBS = ObserverSpec(
    "DObs",
    "hokuyo_dobs",
    (("topic", "/diagnostics"), ("node", "hokuyo_node"), ("device", "hokuyo")),
    (Atom("ok", ("hokuyo",)),),
)


def test_the_rule() -> None:
    check = SourceCheck(SOURCES)
    assert check.reason("/pose", "/jaguar_node", "nav_msgs/Odometry") is None
    assert check.reason("/pose", "jaguar_node", "nav_msgs/msg/Odometry") is None
    assert "not a publisher of /pose" in str(
        check.reason("/pose", "/intruder", "nav_msgs/Odometry")
    )
    wrong = check.reason("/pose", "/jaguar_node", "sensor_msgs/LaserScan")
    assert wrong == "of type sensor_msgs/LaserScan, but the model declares nav_msgs/Odometry"
    assert check.reason("/free", "/anyone", "any/Type") is None  # the model names none
    assert SourceCheck(None).reason("/pose", "/intruder", "x/Y") is None  # an older racc's file
    assert type_name("a/msg/B") == "a/B"


@dataclass
class Conn:
    header: dict[str, str]
    endpoint_id: str


@dataclass
class Impl:
    connections: list[Conn] = field(default_factory=list)
    removed: list[Conn] = field(default_factory=list)

    def remove_connection(self, c: Conn) -> None:
        self.removed.append(c)
        self.connections.remove(c)


def judge(uris: dict[str, str]) -> tuple[Connections, list[tuple[str, str, str]], list[str]]:
    refused: list[tuple[str, str, str]] = []
    asked: list[str] = []

    def lookup(callerid: str) -> str | None:
        asked.append(callerid)
        return uris.get(callerid)

    return Connections(SourceCheck(SOURCES), lambda *r: refused.append(r), lookup), refused, asked


def test_a_connection_is_judged_once_and_a_strangers_is_closed() -> None:
    connections, refused, asked = judge({"/jaguar_node": "http://h:1/", "/intruder": "http://h:2/"})
    ours = Conn({"callerid": "/jaguar_node", "type": "nav_msgs/Odometry"}, "http://h:1/")
    theirs = Conn({"callerid": "/intruder", "type": "nav_msgs/Odometry"}, "http://h:2/")
    impl = Impl([ours, theirs])
    for _ in range(1000):  # a flood: judged once, closed at once
        assert connections.admits("/pose", ours.header, impl)
    assert not connections.admits("/pose", theirs.header, impl)
    assert not connections.admits("/pose", theirs.header, impl)
    assert impl.removed == [theirs] and asked == ["/jaguar_node"]
    assert refused == [
        ("/intruder", "/pose", "not a publisher of /pose in the model (that is jaguar_node)")
    ]


def test_a_forged_callerid_is_found_by_the_masters_record() -> None:
    # A stranger registered as /intruder at :2 writes callerid /jaguar_node in its header.
    connections, refused, _ = judge({"/jaguar_node": "http://h:1/"})
    forged = Conn({"callerid": "/jaguar_node", "type": "nav_msgs/Odometry"}, "http://h:2/")
    impl = Impl([forged])
    assert not connections.admits("/pose", forged.header, impl)
    assert impl.removed == [forged]
    assert "a forged callerid" in refused[0][2]


def test_a_wrong_type_from_anyone_is_refused() -> None:
    connections, refused, _ = judge({"/jaguar_node": "http://h:1/"})
    scan = Conn({"callerid": "/jaguar_node", "type": "sensor_msgs/LaserScan"}, "http://h:1/")
    assert not connections.admits("/pose", scan.header, Impl([scan]))
    assert "but the model declares nav_msgs/Odometry" in refused[0][2]


def test_while_the_master_does_not_answer_a_new_connection_counts_for_nothing() -> None:
    answers: list[Any] = [OSError("refused"), "http://h:1/"]

    def lookup(callerid: str) -> str | None:
        answer = answers.pop(0)
        if isinstance(answer, Exception):
            raise answer
        return str(answer)

    clock = [0.0]
    connections = Connections(SourceCheck(SOURCES), lambda *r: None, lookup, lambda: clock[0])
    ours = Conn({"callerid": "/jaguar_node", "type": "nav_msgs/Odometry"}, "http://h:1/")
    impl = Impl([ours])
    assert not connections.admits("/pose", ours.header, impl)  # undecided: dropped
    assert not connections.admits("/pose", ours.header, impl)  # not asked again at once
    clock[0] = 2.0
    assert connections.admits("/pose", ours.header, impl)
    assert impl.removed == []


def test_a_device_status_counts_only_from_its_reporters() -> None:
    refused: list[tuple[str, str, str]] = []
    host = ObserverHost([DOBS], clock=lambda: 1.0)
    host.refuse = lambda *r: refused.append(r)
    assert device_reporters([DOBS]) == {"hokuyo": frozenset({"hokuyo_node"})}
    host.device_rows([Row("hokuyo", 2, "broken", "hokuyo")], "/intruder")
    assert host.current == {} and "which the model has hokuyo_node report" in refused[0][2]
    host.device_rows([Row("hokuyo_node: hokuyo", 0, "ok", "hokuyo")], "/hokuyo_node")
    assert [str(v) for v in host.current.values()] == ["ok(hokuyo)"]
    host.device_rows([Row("other", 2, "unrelated", "")], "/intruder")  # names no device
    assert len(refused) == 1


def test_a_suspended_topic_feeds_nothing_and_starts_afresh() -> None:
    bank = ObserverBank([GOBS, DOBS])
    for k in range(40):
        bank.feed(Message(k * 0.1, "/pose", {}))
        bank.advance(k * 0.1)
    assert bank.suspend("/pose") == [Atom("ok", ("pose",))]
    assert bank.suspended("/pose") and not bank.suspended("/diagnostics")
    # silence while suspended counts nothing: no verdict at all
    assert bank.advance(60.0) == [] and bank.feed(Message(60.0, "/pose", {})) == []
    bank.resume("/pose")
    assert not bank.suspended("/pose")
    out = []
    for k in range(30):
        out += bank.feed(Message(61.0 + k * 0.1, "/pose", {}))
    assert [str(v) for v in out] == ["ok(pose)"]  # a fresh window, no stale silence
    assert bank.suspend("/diagnostics") == [Atom("ok", ("hokuyo",))]
    assert bank.feed(DeviceStatus(70.0, "hokuyo", "hokuyo", 2)) == []


IOBS = ObserverSpec(
    "IObs",
    "speed_iobs",
    (("topic1", "/pose"), ("field1", "v"), ("topic2", "/pose"), ("field2", "w"), ("max_diff", 1.0)),
    (Atom("equal", ("pose", "v", "pose", "w")),),
)


def test_a_short_pause_keeps_the_value_observers_and_their_verdicts() -> None:
    """A topic resumed after a short pause (a robot's node restarting) keeps what its
    value observers had judged: a relation's history takes many seconds to gather again.
    Its frequency observer starts afresh; after a long pause, all do."""
    now = [0.0]
    host = ObserverHost([GOBS, IOBS], clock=lambda: now[0])
    equal, ok = Atom("equal", ("pose", "v", "pose", "w")), Atom("ok", ("pose",))
    for k in range(40):
        now[0] = k * 0.1
        host.message("/pose", {"v": 1.0, "w": 1.2}, None)
        host.advance()
    assert host.current[equal].positive and host.current[ok].positive
    host.suspend_topic("/pose", "a publisher not judged yet")
    assert equal not in host.current and ok not in host.current
    now[0] = 6.0
    host.resume_topic("/pose")
    assert host.current[equal].positive and host.current[equal].t == 6.0  # holds again
    assert ok not in host.current  # the frequency observer waits for a fresh window
    assert "values kept" in host.notes[-1]
    host.suspend_topic("/pose", "a stranger publishes it too")
    now[0] = 30.0
    host.resume_topic("/pose")
    assert equal not in host.current and ok not in host.current
    assert "(afresh)" in host.notes[-1]
