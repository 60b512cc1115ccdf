"""Reading fields straight from serialized messages (rac.learn.raw) gives what full
deserialization gives, bit for bit, and fails where it fails."""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

import rac.learn.raw as raw
from rac.learn.fields import (
    EULER_FIELDS,
    FieldSelector,
    Layout,
    extractor,
    layout_of,
    row_extractor,
    with_angles,
)
from rac.load.bags import read_recording
from rac.parse import parse_ram
from rac.synth import SynthOptions, plan_recording, write_recording
from rac.synth.types import resolve_type

BENCH = Path(__file__).resolve().parents[2] / "bench" / "learn.py"

STANDARD = [
    "std_msgs/msg/Float64",
    "std_msgs/msg/Float32",
    "std_msgs/msg/Int32",
    "std_msgs/msg/String",
    "std_msgs/msg/Header",
    "std_msgs/msg/Empty",
    "sensor_msgs/msg/Imu",
    "sensor_msgs/msg/LaserScan",
    "sensor_msgs/msg/BatteryState",
    "sensor_msgs/msg/NavSatFix",
    "sensor_msgs/msg/Temperature",
    "sensor_msgs/msg/Range",
    "sensor_msgs/msg/JointState",
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/TwistStamped",
    "geometry_msgs/msg/Quaternion",
]

# Every kind of field, with paddings in all places CDR has them (odd sizes before wide ones,
# strings and sequences of any length before fixed-size fields).
INNER = """
uint8 a
float64[] d
string s
int16 e
"""
WIDE = """
float64 v
uint8 tail
"""
EVERYTHING = """
bool flag
byte b
char c
int8 i8
uint8 u8
int16 i16
uint16 u16
int32 i32
uint32 u32
int64 i64
uint64 u64
float32 f32
string name
float64 after_string
string[2] names
string[] tags
float32[] values
float64[3] fixed
bool[] flags
uint8[] blob
int16[] shorts
float64[] doubles
geometry_msgs/Quaternion q
geometry_msgs/Point[] points
geometry_msgs/Point[2] corners
std_msgs/Header header
racc_test_msgs/Inner[] inners
racc_test_msgs/Inner[2] inner_pair
racc_test_msgs/Wide[2] wide_pair
racc_test_msgs/Wide[] wides
uint8 odd
float64 last
"""


def _bench_model() -> Any:
    spec = importlib.util.spec_from_file_location("bench_learn", BENCH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return parse_ram(module.bench_model(), "bench.ram")


def _store(ros: int) -> tuple[Typestore, list[str]]:
    """A typestore with the bench bag's types, the standard ones above and EVERYTHING."""
    store = get_typestore(Stores.ROS1_NOETIC if ros == 1 else Stores.ROS2_HUMBLE)
    types: dict[str, Any] = {}
    types.update(get_types_from_msg(INNER, "racc_test_msgs/msg/Inner"))
    types.update(get_types_from_msg(WIDE, "racc_test_msgs/msg/Wide"))
    types.update(get_types_from_msg(EVERYTHING, "racc_test_msgs/msg/Everything"))
    store.register(types)
    names = {resolve_type(t, store) for t in _bench_model().topics}
    return store, sorted(names | set(STANDARD) | {"racc_test_msgs/msg/Everything"})


STORES = {ros: _store(ros) for ros in (1, 2)}

_INTS = {
    "byte": (-128, 127),
    "char": (0, 255),
    "int8": (-128, 127),
    "uint8": (0, 255),
    "int16": (-(2**15), 2**15 - 1),
    "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1),
    "uint64": (0, 2**64 - 1),
}
_ARRAY_DTYPES = {"bool": np.uint8, "byte": np.int8, "char": np.uint8} | {
    t: np.dtype(t) for t in ("int8", "uint8", "int16", "uint16", "int32", "uint32")
}
_ARRAY_DTYPES |= {t: np.dtype(t) for t in ("int64", "uint64", "float32", "float64")}


def _value(typ: str) -> st.SearchStrategy[Any]:
    if typ == "bool":
        return st.booleans()
    if typ == "string":
        return st.text(max_size=5)
    if typ == "float32":
        return st.floats(width=32)
    if typ == "float64":
        return st.floats()
    lo, hi = _INTS[typ]
    return st.integers(lo, hi)


def _draw_message(data: st.DataObject, store: Typestore, typename: str) -> Any:
    kwargs: dict[str, Any] = {}
    # rosbags types a field as a union over its node types, told apart below by nodetype
    fields: Any = store.fielddefs[typename][1]
    for name, (nodetype, detail) in fields:
        if nodetype == Nodetype.BASE:
            kwargs[name] = data.draw(_value(detail[0]))
        elif nodetype == Nodetype.NAME:
            kwargs[name] = _draw_message(data, store, detail)
        else:
            (inner_type, inner), length = detail
            if nodetype == Nodetype.SEQUENCE:
                length = data.draw(st.integers(0, 3))
            if inner_type == Nodetype.NAME:
                kwargs[name] = [_draw_message(data, store, inner) for _ in range(length)]
            elif inner[0] == "string":
                kwargs[name] = data.draw(
                    st.lists(_value("string"), min_size=length, max_size=length)
                )
            else:
                # Bools as raw bytes: a stored 2 must read the same both ways.
                item = st.integers(0, 255) if inner[0] == "bool" else _value(inner[0])
                items = data.draw(st.lists(item, min_size=length, max_size=length))
                kwargs[name] = np.array(items, dtype=_ARRAY_DTYPES[inner[0]])
    return store.types[typename](**kwargs)


def _serialize(store: Typestore, ros: int, msg: Any, typename: str) -> bytes:
    if ros == 1:
        return bytes(store.serialize_ros1(msg, typename))
    return bytes(store.serialize_cdr(msg, typename))


def _deserialize(store: Typestore, ros: int, data: bytes, typename: str) -> object:
    if ros == 1:
        return store.deserialize_ros1(data, typename)
    return store.deserialize_cdr(data, typename)


def _draw_layout(data: st.DataObject, store: Typestore, typename: str) -> Layout:
    """Every field of the type (arrays and header fields too), or a random part of them."""
    whole = layout_of(store.fielddefs, typename, "/t", FieldSelector(None, ("*",)))
    if data.draw(st.booleans()):
        return whole

    def part(items: tuple[str, ...]) -> tuple[str, ...]:
        keep = data.draw(st.lists(st.booleans(), min_size=len(items), max_size=len(items)))
        return tuple(p for p, k in zip(items, keep, strict=True) if k)

    euler = part(whole.euler)
    return Layout(
        part(whole.scalars), part(whole.arrays), whole.quaternion if euler else None, euler
    )


def _bits(row: tuple[float, ...]) -> bytes:
    return np.asarray(row, dtype=np.float64).tobytes()


def _outcome(read: Any, data: bytes) -> tuple[str, Any, Any]:
    try:
        return ("row", _bits(read(data)), None)
    except Exception as err:  # the failure itself is what is compared
        return ("error", type(err), str(err))


def _drawn(data: st.DataObject, ros: int) -> tuple[Any, str, Any, bytes]:
    """A random message type of ROS ``ros``, fields to read from it, and one serialized
    message: the store, the type's name, the layout, the bytes."""
    store, names = STORES[ros]
    typename = data.draw(st.sampled_from(names))
    layout = _draw_layout(data, store, typename)
    return (
        store,
        typename,
        layout,
        _serialize(store, ros, _draw_message(data, store, typename), typename),
    )


def _on_random_messages(test: Callable[..., None]) -> Callable[..., None]:
    """Run ``test(ros, data)`` for ROS 1 and ROS 2, on 400 drawings each (hypothesis)."""
    test = given(data=st.data())(test)
    test = settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])(
        test
    )
    test = pytest.mark.parametrize("ros", [1, 2])(test)
    # means of extreme random values warn
    marked: Callable[..., None] = pytest.mark.filterwarnings("ignore::RuntimeWarning")(test)
    return marked


@pytest.mark.slow
@_on_random_messages
def test_the_walk_reads_what_deserialization_reads(ros: int, data: st.DataObject) -> None:
    store, typename, layout, message = _drawn(data, ros)
    walk = raw.raw_row_reader(
        store.fielddefs, typename, layout, cdr=ros == 2, max_sequence=store.max_sequence_length
    )
    assert walk is not None, typename
    expected = row_extractor(layout)(_deserialize(store, ros, message, typename))
    assert _bits(walk(message)) == _bits(expected)


def _damage(data: st.DataObject, message: bytes) -> bytes:
    how = data.draw(st.sampled_from(["truncate", "byte", "append"]))
    if how == "truncate":
        return message[: data.draw(st.integers(0, max(0, len(message) - 1)))]
    if how == "append":
        return message + data.draw(st.binary(min_size=1, max_size=9))
    if not message:
        return b"\x00"
    at = data.draw(st.integers(0, len(message) - 1))
    return message[:at] + bytes([data.draw(st.integers(0, 255))]) + message[at + 1 :]


@pytest.mark.slow
@_on_random_messages
def test_a_damaged_message_fails_as_deserialization_fails(ros: int, data: st.DataObject) -> None:
    """Whatever the damage, the reader gives deserialization's row or its very error."""
    store, typename, layout, message = _drawn(data, ros)
    damaged = _damage(data, message)
    read = raw.row_reader(store, typename, layout, cdr=ros == 2)
    full_row = row_extractor(layout)

    def full(data: bytes) -> tuple[float, ...]:
        return full_row(_deserialize(store, ros, data, typename))

    assert _outcome(read, damaged) == _outcome(full, damaged)


def test_a_big_endian_cdr_message_is_read_the_full_way() -> None:
    store, _ = STORES[2]
    typename = "geometry_msgs/msg/Quaternion"
    layout = layout_of(store.fielddefs, typename, "/q", FieldSelector())
    msg = store.types[typename](x=0.1, y=0.2, z=0.3, w=0.9)
    little = bytes(store.serialize_cdr(msg, typename))
    big = bytes(store.serialize_cdr(msg, typename, little_endian=False))
    walk = raw.raw_row_reader(store.fielddefs, typename, layout, cdr=True, max_sequence=9)
    assert walk is not None
    with pytest.raises(raw.Damaged):
        walk(big)
    read = raw.row_reader(store, typename, layout, cdr=True)
    # The scalars, then the quaternion again for the angles (a quaternion topic's own).
    assert read(big) == read(little) == walk(little) == (0.1, 0.2, 0.3, 0.9) * 2
    values = with_angles(layout, np.array([read(big)]))
    assert layout.fields == ("x", "y", "z", "w", "yaw", "pitch", "roll")
    assert values.tolist() == [[0.1, 0.2, 0.3, 0.9, *extractor(layout)(msg)[4:]]]
    assert len(extractor(layout)(msg)) == 7


def test_types_the_walk_does_not_know_go_the_full_way() -> None:
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg("float64 a\n", "racc_test_msgs/msg/Plain"))
    layout = Layout(("a",), (), None, ())
    fielddefs = dict(store.fielddefs)
    fielddefs["racc_test_msgs/msg/Odd"] = ([], [("a", (Nodetype.BASE, ("float128", 0)))])
    assert (
        raw.raw_row_reader(fielddefs, "racc_test_msgs/msg/Odd", layout, cdr=True, max_sequence=9)
        is None
    )
    assert raw.raw_row_reader(
        fielddefs, "racc_test_msgs/msg/Plain", layout, cdr=True, max_sequence=9
    )


@settings(max_examples=200, deadline=None)
@given(q=st.lists(st.floats(-1.5, 1.5), min_size=4, max_size=4))
def test_angles_per_column_are_the_angles_per_message(q: list[float]) -> None:
    """Learning derives yaw/pitch/roll per column; observers at run time per message:
    the two must give the same bits, or learned bounds would not fit observed values."""
    layout = Layout((), (), "", EULER_FIELDS)

    class Quaternion:
        x, y, z, w = q

    per_message = extractor(layout)(Quaternion())
    per_column = with_angles(layout, np.array([q, q], dtype=np.float64))
    assert per_column.shape == (2, 3)
    assert _bits(per_message) == per_column[0].tobytes() == per_column[1].tobytes()


@pytest.mark.slow
@pytest.mark.parametrize("ros", [1, 2])
def test_a_bench_recording_reads_the_same_both_ways(
    ros: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """bench/learn.py's 20 topics, a few seconds of them: the values read from the bytes are
    those of full deserialization, bit for bit, for the model's fields and for all fields."""
    model = _bench_model()
    run = tmp_path / ("run.bag" if ros == 1 else "run")
    write_recording(plan_recording(model, SynthOptions(4.0, 1, ros)), run)
    declared = {t.name.value: frozenset(f.value for f in t.fields) for t in model.topics}
    selectors = [FieldSelector(declared), FieldSelector(None, ("*",))]
    # The model's 20 topics (synth adds the board's /board_measurements, which is racc's).
    topics = frozenset(t.name.value for t in model.topics)
    fast = [read_recording([run], s, topics) for s in selectors]
    monkeypatch.setattr(raw, "raw_row_reader", lambda *_, **__: None)
    full = [read_recording([run], s, topics) for s in selectors]
    for a, b in zip(fast, full, strict=True):
        assert len(a.topics) == 20
        for ta, tb in zip(a.topics, b.topics, strict=True):
            assert (ta.name, ta.fields) == (tb.name, tb.fields)
            assert ta.values.tobytes() == tb.values.tobytes(), ta.name


@pytest.mark.parametrize("ros", [1, 2])
def test_a_string_that_is_not_utf8_fails_as_deserialization_fails(ros: int) -> None:
    store, _ = STORES[ros]
    typename = "sensor_msgs/msg/Temperature"  # header.frame_id, then the wanted numbers
    layout = layout_of(store.fielddefs, typename, "/t", FieldSelector())
    msg = _draw_example(store, typename)
    good = _serialize(store, ros, msg, typename)
    bad = good.replace(b"abc", b"a\xffc")
    walk = raw.raw_row_reader(store.fielddefs, typename, layout, cdr=ros == 2, max_sequence=9)
    assert walk is not None and walk(good) == (21.5, 0.25)
    with pytest.raises(UnicodeDecodeError):
        walk(bad)
    read = raw.row_reader(store, typename, layout, cdr=ros == 2)
    error = _outcome(read, bad)
    assert error[0] == "error" and "Could not deserialize" in error[2]
    assert error == _outcome(lambda d: _deserialize(store, ros, d, typename), bad)


def _draw_example(store: Typestore, typename: str) -> Any:
    types = store.types
    header = types["std_msgs/msg/Header"]
    stamp = types["builtin_interfaces/msg/Time"](sec=1, nanosec=2)
    # rosbags' message classes are dataclasses; its MsgType protocol does not say so
    header_fields = header.__dataclass_fields__  # type: ignore[attr-defined]
    kwargs = {"seq": 3} if "seq" in header_fields else {}
    return types[typename](
        header=header(stamp=stamp, frame_id="abc", **kwargs), temperature=21.5, variance=0.25
    )
