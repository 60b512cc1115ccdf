"""Hand-computed traces for NObs, PObs, DObs, HObs and IObs, and the θ rule."""

from __future__ import annotations

import math

import pytest

from rac.errors import RacError
from rac.logic import Atom
from rac.observe import (
    ChannelState,
    DeviceStatus,
    Message,
    NodeSample,
    PropertySample,
    Verdict,
    build,
)
from rac.observe.base import Mismatch
from rac.observe.dobs import names_device
from rac.passes.observers import ObserverSpec, ParamValue


def spec(kind: str, atoms: tuple[Atom, ...], **params: ParamValue) -> ObserverSpec:
    return ObserverSpec(kind, f"test_{kind.lower()}", tuple(params.items()), atoms)


def trace(verdicts: list[Verdict]) -> list[tuple[float, str]]:
    return [(v.t, str(v)) for v in verdicts]


RUNNING = Atom("running", ("jaguar_node",))


def test_mismatch_counts_net_violations_and_is_bounded() -> None:
    m = Mismatch(2)  # negative while count > 2; bounded at 2·2 + 1 = 5
    assert [m.check(False) for _ in range(3)] == [True, True, False]  # counts 1, 2, 3
    assert m.check(True)  # 3 -> 2: positive again
    for _ in range(10):
        m.check(False)
    assert m.count == 5  # the bound
    assert [m.check(True) for _ in range(3)] == [False, False, True]  # 4, 3, 2


def test_nobs_crash_after_theta_samples_and_recovery() -> None:
    obs = build(spec("NObs", (RUNNING,), node="/jaguar_node", mismatch_th=2))
    samples = [True, True, False, False, False, True]
    out = []
    for i, running in enumerate(samples):
        out += obs.feed(NodeSample(float(i), "jaguar_node", running))
    # t0: count 0 -> running (first verdict); t1: no change; t2, t3: counts 1, 2 <= θ;
    # t4: count 3 > θ -> not running; t5: count 2 -> running again.
    assert trace(out) == [
        (0.0, "running(jaguar_node)"),
        (4.0, "not_running(jaguar_node)"),
        (5.0, "running(jaguar_node)"),
    ]
    # Other nodes' samples are not this observer's.
    assert obs.feed(NodeSample(6.0, "hokuyo_node", False)) == []
    assert obs.advance(100.0) == []


def test_nobs_long_crash_needs_theta_plus_one_good_samples() -> None:
    obs = build(spec("NObs", (RUNNING,), node="jaguar_node", mismatch_th=2))
    out = []
    for i in range(20):  # counts 1..5, then held at the bound 5
        out += obs.feed(NodeSample(float(i), "jaguar_node", False))
    for i in range(20, 25):  # counts 4, 3, 2 (positive at t22), 1, 0
        out += obs.feed(NodeSample(float(i), "jaguar_node", True))
    assert trace(out) == [
        (0.0, "running(jaguar_node)"),  # count 1 <= θ
        (2.0, "not_running(jaguar_node)"),  # count 3
        (22.0, "running(jaguar_node)"),
    ]


CPU = Atom("ok", ("hector_mapping", "cpu"))


def test_pobs_window_fill_up_and_overload() -> None:
    obs = build(
        spec("PObs", (CPU,), node="hector_mapping", property="cpu", max_val=10.0, mismatch_th=2)
    )
    values = [30.0] * 6 + [0.0] * 9
    out = []
    for i, v in enumerate(values, start=1):
        out += obs.feed(PropertySample(float(i), "hector_mapping", "cpu", v))
    # The queue starts as ten zeros: after k samples of 30 the mean is 3k.
    # k=1..3: 3, 6, 9 <= 10 ok (first verdict at t1); k=4, 5, 6: 12, 15, 18 -> counts 1, 2, 3:
    # not ok at t6.  Samples 7-10 (zeros) push out the leading zeros: the mean stays 18
    # (counts 4, 5, then held at the bound 5).  Samples 11, 12 push out 30s: means 15, 12
    # (count 5); 13, 14, 15: means 9, 6, 3 -> counts 4, 3, 2: ok at t15.
    assert trace(out) == [
        (1.0, "ok(hector_mapping,cpu)"),
        (6.0, "not_ok(hector_mapping,cpu)"),
        (15.0, "ok(hector_mapping,cpu)"),
    ]
    # The other property of the node is not this observer's.
    assert obs.feed(PropertySample(16.0, "hector_mapping", "mem", 1e12)) == []


HOKUYO = Atom("ok", ("hokuyo",))


def test_dobs_ok_warn_error_stale() -> None:
    obs = build(
        spec(
            "DObs",
            (HOKUYO,),
            topic="/diagnostics",
            node="hokuyo_node",
            device="hokuyo",
            mismatch_th=1,
        )
    )
    statuses = [
        DeviceStatus(1.0, "hokuyo_node: hokuyo", "", 0),  # OK: count 0 -> ok
        DeviceStatus(2.0, "hokuyo_node: Connection", "", 3),  # another device: ignored
        DeviceStatus(3.0, "/Hokuyo", "", 1),  # WARN is fine: count 0
        DeviceStatus(4.0, "laser", "hokuyo", 2),  # ERROR (by hardware_id): count 1 <= θ
        DeviceStatus(5.0, "hokuyo: driver", "", 3),  # STALE: count 2 > θ -> not ok
        DeviceStatus(6.0, "hokuyo", "", 0),  # OK: count 1 -> ok
    ]
    out = []
    for status in statuses:
        out += obs.feed(status)
    assert trace(out) == [(1.0, "ok(hokuyo)"), (5.0, "not_ok(hokuyo)"), (6.0, "ok(hokuyo)")]


@pytest.mark.parametrize(
    ("name", "hardware_id", "expected"),
    [
        ("hokuyo", "", True),
        ("/HOKUYO", "", True),
        ("", "Hokuyo", True),
        ("hokuyo_node: hokuyo", "", True),
        ("hokuyo: Connection Status", "", True),
        ("a: b: hokuyo", "", True),
        ("hokuyo_node: Connection Status", "", False),
        ("hokuyo2", "hokuyo_x", False),
    ],
)
def test_dobs_names_device(name: str, hardware_id: str, expected: bool) -> None:
    assert names_device(DeviceStatus(0.0, name, hardware_id, 0), "hokuyo") is expected


def test_hobs_reports_each_channel_at_once() -> None:
    atoms = (Atom("on", ("jaguar",)), Atom("on", ("hokuyo",)))
    obs = build(spec("HObs", atoms, topic="/board_measurements", channels="jaguar:1,hokuyo:2"))
    events = [
        ChannelState(0.0, 1, True),  # on(jaguar)
        ChannelState(0.0, 2, False),  # not on(hokuyo): no θ, at once
        ChannelState(0.1, 1, True),  # no change
        ChannelState(0.1, 3, True),  # a channel it does not watch
        ChannelState(0.2, 2, True),  # on(hokuyo)
        ChannelState(0.3, 1, False),  # not on(jaguar)
    ]
    out = []
    for event in events:
        out += obs.feed(event)
    assert trace(out) == [
        (0.0, "on(jaguar)"),
        (0.0, "not_on(hokuyo)"),
        (0.2, "on(hokuyo)"),
        (0.3, "not_on(jaguar)"),
    ]
    assert obs.needs.channels == (1, 2)


EQUAL = Atom("equal", ("imu_data", "pitch", "la_servo1_moving", "angle"))


def test_iobs_checks_every_message_once_both_values_are_known() -> None:
    obs = build(
        spec(
            "IObs",
            (EQUAL,),
            topic1="/imu_data",
            field1="pitch",
            topic2="/la_servo1_moving",
            field2="angle",
            mismatch_th=1,
            max_diff=0.05,
        )
    )
    messages = [
        Message(1.0, "/imu_data", {"pitch": 0.10}),  # v2 unknown: no check
        Message(2.0, "/la_servo1_moving", {"angle": 0.12}),  # |0.10-0.12| = 0.02: ok
        Message(3.0, "/imu_data", {"pitch": 0.30}),  # 0.18 > 0.05: count 1 <= θ
        Message(3.5, "/imu_data", {"yaw": 0.30}),  # no pitch: no check
        Message(3.6, "/imu_data", {"pitch": math.nan}),  # not available: no check
        Message(4.0, "/la_servo1_moving", {"angle": 0.12}),  # 0.18: count 2 -> not equal
        Message(5.0, "/la_servo1_moving", {"angle": 0.29}),  # 0.01: count 1 -> equal
        Message(6.0, "/scan", {"angle": 9.0}),  # another topic
    ]
    out = []
    for m in messages:
        out += obs.feed(m)
    name = "equal(imu_data,pitch,la_servo1_moving,angle)"
    assert trace(out) == [(2.0, name), (4.0, "not_" + name), (5.0, name)]


def test_iobs_one_topic_message_is_one_check() -> None:
    atom = Atom("equal", ("pose", "a", "pose", "b"))
    obs = build(
        spec(
            "IObs",
            (atom,),
            topic1="/pose",
            field1="a",
            topic2="/pose",
            field2="b",
            mismatch_th=0,
            max_diff=1.0,
        )
    )
    assert trace(obs.feed(Message(0.0, "/pose", {"a": 0.0, "b": 0.5}))) == [(0.0, str(atom))]
    # θ = 0: one violation turns it.
    assert trace(obs.feed(Message(1.0, "/pose", {"a": 0.0, "b": 2.0}))) == [(1.0, f"not_{atom}")]


@pytest.mark.parametrize(
    ("kind", "params", "code", "words"),
    [
        ("XObs", {}, "RAC050", "unknown observer kind"),
        ("NObs", {}, "RAC050", "missing parameter 'node'"),
        ("NObs", {"node": "a", "mismatch_th": "five"}, "RAC050", "mismatch_th"),
        ("GObs", {"topic": "/x", "delta": 0.0}, "RAC051", "delta"),
        ("GObs", {"topic": "/x", "delta": "fast"}, "RAC050", "delta"),
        ("PObs", {"node": "a", "property": "disk", "max_val": 1.0}, "RAC051", "cpu or mem"),
        ("HObs", {"channels": "jaguar"}, "RAC051", "device:channel"),
        (
            "BiQObs",
            {"topic1": "/a", "field1": "x", "topic2": "/b", "field2": "y", "integral1": "maybe"},
            "RAC050",
            "integral1",
        ),
    ],
)
def test_build_rejects_bad_specs(
    kind: str, params: dict[str, ParamValue], code: str, words: str
) -> None:
    with pytest.raises(RacError) as caught:
        build(spec(kind, (Atom("ok", ("x",)),), **params))
    diagnostic = caught.value.diagnostics[0]
    assert diagnostic.code == code
    assert words in diagnostic.message
    assert f"test_{kind.lower()}" in diagnostic.message  # names the observer
