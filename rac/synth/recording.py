"""Plan and write a synthetic recording of the robot a model describes (``racc synth``)."""

from __future__ import annotations

import heapq
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.interfaces import Connection
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys.store import Typestore

from rac.ir import Model
from rac.learn.fields import FloatArray, quaternion_from_euler
from rac.synth.faults import Fault
from rac.synth.properties import properties_csv
from rac.synth.sensors import Content, content, role_of
from rac.synth.timing import publication_times
from rac.synth.types import DTYPES, MessageFactory, leaf_types, new_typestore, resolve_type
from rac.synth.world import simulate

EPOCH_S = 1_600_000_000  # recordings start here (plus one hour per seed) in ROS time
# The board client's measurements: one diagnostic_msgs/DiagnosticArray with a "channel N"
# status per switchable device on a channel, as racc's board client publishes them.
BOARD_TOPIC = "/board_measurements"
BOARD_TYPE = "diagnostic_msgs/msg/DiagnosticArray"
BOARD_PUBLISHER = "racc_board_client"
BOARD_HZ = 2.0


@dataclass(frozen=True, slots=True)
class SynthOptions:
    duration: float = 120.0
    seed: int = 0
    ros_version: int = 1
    storage: str = "sqlite3"  # ROS 2 only: sqlite3 or mcap
    faults: tuple[Fault, ...] = ()


# (parent attribute path, attribute, value per message), ready to assign.
Assignment = tuple[tuple[str, ...], str, list[Any]]


@dataclass(frozen=True, slots=True)
class PlannedTopic:
    name: str
    typename: str  # typestore name
    publisher: str
    times: FloatArray  # seconds from the start
    content: Content
    leaves: dict[str, str]
    assignments: tuple[Assignment, ...]


@dataclass(frozen=True, slots=True)
class Plan:
    options: SynthOptions
    start_s: float
    store: Typestore
    topics: tuple[PlannedTopic, ...]
    properties: str  # the CSV text
    factory: MessageFactory
    board: tuple[tuple[int, str], ...] = ()  # (channel, device) on the board
    board_times: FloatArray = field(default_factory=lambda: np.empty(0))

    @property
    def messages(self) -> int:
        return sum(t.times.size for t in self.topics)


def plan_recording(model: Model, options: SynthOptions) -> Plan:
    """Everything to write, decided up front and deterministic for a seed."""
    rng = np.random.default_rng(options.seed)
    world = simulate(options.duration, rng, options.faults)
    schedule = publication_times(model, options.duration, options.faults, rng)
    store = new_typestore(options.ros_version)
    publishers = model.publishers()
    planned: list[PlannedTopic] = []
    servos = 0
    for topic in sorted(model.topics, key=lambda t: t.name.value):
        name = topic.name.value
        if name not in schedule:
            continue
        typename = resolve_type(topic, store)
        leaves = leaf_types(store, typename)
        role = role_of(topic)
        times = schedule[name]
        c = content(topic, role, times, world, rng, servos, leaves)
        servos += role == "servo"
        assignments = _assignments(c, leaves, times, float(EPOCH_S + 3600 * options.seed))
        planned.append(
            PlannedTopic(name, typename, publishers[name][0], times, c, leaves, assignments)
        )
    start = float(EPOCH_S + 3600 * options.seed)
    csv = properties_csv(model, options.duration, options.faults, rng)
    board = tuple(
        sorted((h.channel, h.name.value) for h in model.hardware if h.switchable and h.channel)
    )
    times = np.arange(0.0, options.duration, 1.0 / BOARD_HZ) if board else np.empty(0)
    return Plan(options, start, store, tuple(planned), csv, MessageFactory(store), board, times)


def board_message(plan: Plan, t: float) -> Any:
    """The board's measurement at ``t``: every channel on, unless a trip holds it off."""
    types = plan.store.types
    stamp = plan.start_s + t
    header = (
        types["std_msgs/msg/Header"](
            seq=0,
            stamp=types["builtin_interfaces/msg/Time"](
                sec=int(stamp), nanosec=int(stamp % 1 * 1e9)
            ),
            frame_id="",
        )
        if plan.options.ros_version == 1
        else types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](
                sec=int(stamp), nanosec=int(stamp % 1 * 1e9)
            ),
            frame_id="",
        )
    )
    status, value = (
        types["diagnostic_msgs/msg/DiagnosticStatus"],
        types["diagnostic_msgs/msg/KeyValue"],
    )
    tripped = {f.target for f in plan.options.faults if f.kind == "trip" and f.active(t)}
    rows = []
    for channel, device in plan.board:
        on = device not in tripped
        values = [value(key="on", value="1" if on else "0")]
        rows.append(
            status(
                level=0,
                name=f"channel {channel}",
                message="on" if on else "off",
                hardware_id=device,
                values=values,
            )
        )
    return types[BOARD_TYPE](header=header, status=rows)


def _assign(path: str, values: list[Any]) -> Assignment:
    parents, _, last = path.rpartition(".")
    return (tuple(parents.split(".")) if parents else (), last, values)


def _typed(values: FloatArray, base: str) -> list[Any]:
    """Values as the Python numbers the serializer expects for ``base``."""
    if base in ("float32", "float64"):
        return [float(v) for v in values.tolist()]
    if base == "bool":
        return [bool(v) for v in (values > 0).tolist()]
    rounded = np.rint(values)
    if base.startswith("u") or base in ("byte", "char", "octet"):
        rounded = np.maximum(rounded, 0)
    return [int(v) for v in rounded.tolist()]


def _assignments(
    c: Content, leaves: dict[str, str], times: FloatArray, start_s: float
) -> tuple[Assignment, ...]:
    out: list[Assignment] = []
    if "header.stamp.sec" in leaves:
        stamps = np.rint((start_s + times) * 1e9).astype(np.int64)
        out.append(_assign("header.stamp.sec", (stamps // 1_000_000_000).tolist()))
        out.append(_assign("header.stamp.nanosec", (stamps % 1_000_000_000).tolist()))
        out.append(_assign("header.frame_id", [c.frame_id] * times.size))
        if "header.seq" in leaves:
            out.append(_assign("header.seq", list(range(times.size))))
    for path, values in c.scalars.items():
        if path in leaves:
            out.append(_assign(path, _typed(values, leaves[path])))
    if c.orientation is not None and f"{c.orientation[0]}.w" in leaves:
        path, yaw, pitch, roll = c.orientation
        quaternion = quaternion_from_euler(yaw, pitch, roll)
        for axis, values in zip("xyzw", quaternion, strict=True):
            out.append(_assign(f"{path}.{axis}", [float(v) for v in values.tolist()]))
    return tuple(out)


def _set(msg: Any, path: str, value: Any) -> None:
    if "." not in path:
        setattr(msg, path, value)
        return
    parents, _, last = path.rpartition(".")
    for p in parents.split("."):
        msg = getattr(msg, p)
    setattr(msg, last, value)


def build_message(plan: Plan, topic: PlannedTopic, i: int) -> Any:
    msg = plan.factory.new(topic.typename)
    for parents, last, values in topic.assignments:
        target = msg
        for p in parents:
            target = getattr(target, p)
        setattr(target, last, values[i])
    for path, array_at in topic.content.arrays.items():
        base = topic.leaves.get(path + "[]")
        if base is not None:
            _set(msg, path, np.asarray(array_at(i), dtype=DTYPES[base]))
    return msg


def _in_time_order(plan: Plan) -> Iterator[tuple[int, int]]:
    """(topic index, message index) of every message, by publication time; the board's
    measurements come as the topic index after the last topic."""

    def stream(k: int, times: FloatArray) -> Iterator[tuple[float, int, int]]:
        for i, t in enumerate(times.tolist()):
            yield t, k, i

    streams = [stream(k, topic.times) for k, topic in enumerate(plan.topics)]
    streams.append(stream(len(plan.topics), plan.board_times))
    for _, k, i in heapq.merge(*streams):
        yield k, i


def write_recording(plan: Plan, path: Path) -> int:
    """Write the bag (a ROS 1 file or a ROS 2 directory) at a path that must not exist yet."""
    store = plan.store
    if plan.options.ros_version == 1:
        with Writer1(path) as writer1:
            conns = [
                writer1.add_connection(
                    t.name, t.typename, typestore=store, callerid=f"/{t.publisher}"
                )
                for t in plan.topics
            ]
            if plan.board:
                conns.append(
                    writer1.add_connection(
                        BOARD_TOPIC, BOARD_TYPE, typestore=store, callerid=f"/{BOARD_PUBLISHER}"
                    )
                )
            return _write_messages(plan, conns, writer1.write, store.serialize_ros1)
    plugin = StoragePlugin.MCAP if plan.options.storage == "mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=9, storage_plugin=plugin) as writer2:
        conns = [writer2.add_connection(t.name, t.typename, typestore=store) for t in plan.topics]
        if plan.board:
            conns.append(writer2.add_connection(BOARD_TOPIC, BOARD_TYPE, typestore=store))
        return _write_messages(plan, conns, writer2.write, store.serialize_cdr)


def _write_messages(
    plan: Plan,
    conns: Sequence[Connection],
    write: Callable[[Connection, int, memoryview], None],
    serialize: Callable[[object, str], memoryview],
) -> int:
    """Every planned message, in time order, through one bag writer; how many."""
    count = 0
    for k, i in _in_time_order(plan):
        if k == len(plan.topics):
            t = float(plan.board_times[i])
            message = serialize(board_message(plan, t), BOARD_TYPE)
            write(conns[k], round((plan.start_s + t) * 1e9), message)
            count += 1
            continue
        topic = plan.topics[k]
        stamp = round((plan.start_s + float(topic.times[i])) * 1e9)
        write(conns[k], stamp, serialize(build_message(plan, topic, i), topic.typename))
        count += 1
    return count


def planned_rates(plan: Plan) -> dict[str, float]:
    """The true mean rate of every topic as planned (for checks and reports)."""
    return {
        t.name: (t.times.size - 1) / float(t.times[-1] - t.times[0])
        for t in plan.topics
        if t.times.size > 1
    }


def fault_summary(faults: Sequence[Fault]) -> list[str]:
    return [
        f"{f.kind} at {f.start:g} s"
        + (f" for {f.duration:g} s" if f.duration is not None else "")
        + f" on {f.target}"
        for f in faults
    ]
