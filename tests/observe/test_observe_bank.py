"""ObserverBank routing, ObservationSet (Algorithm 10), and the models' observers on a
synthetic healthy stream."""

from __future__ import annotations

import math
import random
from pathlib import Path

import pytest

from rac.diagnosis.theory import Literal
from rac.load.files import load_model
from rac.logic import Atom
from rac.observe import (
    ChannelState,
    DeviceStatus,
    Event,
    Message,
    NodeSample,
    ObservationSet,
    ObserverBank,
    PropertySample,
    Verdict,
)
from rac.observe.gobs import GObs
from rac.observe.pobs import PObs
from rac.passes.observers import ObserverSpec
from rac.pipeline import compile_model

MODELS = Path(__file__).resolve().parents[2] / "models"


RUN_A, RUN_B = Atom("running", ("a",)), Atom("running", ("b",))
PAIR = (("topic1", "/x"), ("field1", "v"), ("topic2", "/z"), ("field2", "w"))


def specs() -> list[ObserverSpec]:
    return [
        ObserverSpec(
            "NObs", "a_nobs", (("node", "a"), ("mismatch_th", 0)), (Atom("running", ("a",)),)
        ),
        ObserverSpec(
            "NObs", "b_nobs", (("node", "/b"), ("mismatch_th", 0)), (Atom("running", ("b",)),)
        ),
        ObserverSpec(
            "GObs",
            "x_gobs",
            (("topic", "/x"), ("delta", 0.25), ("dev", 0.05), ("ws", 1.0), ("mismatch_th", 0)),
            (Atom("ok", ("x",)),),
        ),
        ObserverSpec(
            "GObs",
            "y_gobs",
            (("topic", "/y"), ("delta", 0.25), ("dev", 0.05), ("ws", 1.0), ("mismatch_th", 0)),
            (Atom("ok", ("y",)),),
        ),
        ObserverSpec(
            "PObs",
            "a_cpu_pobs",
            (("node", "a"), ("property", "cpu"), ("max_val", 1.0), ("mismatch_th", 0)),
            (Atom("ok", ("a", "cpu")),),
        ),
        ObserverSpec(
            "DObs",
            "dev_dobs",
            (("topic", "/diagnostics"), ("node", "a"), ("device", "dev")),
            (Atom("ok", ("dev",)),),
        ),
        ObserverSpec(
            "HObs",
            "board_hobs",
            (("topic", "/board_measurements"), ("channels", "m:2,n:1")),
            (Atom("on", ("m",)), Atom("on", ("n",))),
        ),
        ObserverSpec(
            "IObs",
            "i_iobs",
            (
                ("topic1", "/x"),
                ("field1", "v"),
                ("topic2", "/z"),
                ("field2", "w"),
                ("max_diff", 1.0),
            ),
            (Atom("equal", ("x", "v", "z", "w")),),
        ),
    ]


def test_bank_inputs() -> None:
    bank = ObserverBank(specs())
    assert bank.topic_fields() == {
        "/x": frozenset({"v"}),
        "/y": frozenset(),
        "/z": frozenset({"w"}),
    }
    assert bank.nodes == frozenset({"a", "b"})
    assert bank.properties == frozenset({("a", "cpu")})
    assert bank.devices == frozenset({"dev"})
    assert bank.needs_board


def test_bank_routes_each_event_to_its_observers() -> None:
    bank = ObserverBank(specs())
    cases: list[tuple[Event, list[str]]] = [
        (NodeSample(0.0, "/a", True), ["running(a)"]),
        (NodeSample(0.0, "b", False), ["not_running(b)"]),
        (NodeSample(0.0, "c", False), []),
        (PropertySample(0.0, "a", "cpu", 50.0), ["not_ok(a,cpu)"]),  # mean 50/10 > 1, θ = 0
        (PropertySample(0.0, "a", "mem", 50.0), []),
        (DeviceStatus(0.0, "a: dev", "", 2), ["ok(dev)"]),  # ERROR, count 1 <= θ = 5
        (DeviceStatus(0.0, "other", "", 2), []),
        (ChannelState(0.0, 1, True), ["on(n)"]),
        (Message(0.0, "/x", {"v": 0.0}), []),  # GObs starts its window; IObs lacks w
        (Message(0.1, "/z", {"w": 0.5}), ["equal(x,v,z,w)"]),
        (Message(0.2, "/q", {}), []),
    ]
    for event, expected in cases:
        assert [str(v) for v in bank.feed(event)] == expected, event


def test_bank_orders_by_observer_then_atom() -> None:
    bank = ObserverBank(specs())
    for t in (0.0, 0.25, 0.5):
        bank.feed(Message(t, "/y", {}))
        bank.feed(Message(t, "/x", {}))
    # Both windows end at 0.5; at 2.0 both count silent violations (θ = 0): x before y.
    assert [str(v) for v in bank.advance(2.0)] == ["not_ok(x)", "not_ok(y)"]
    # One channel state per call; both channels in one call come in atom order through
    # the sort within an observer.
    out: list[Verdict] = []
    out += bank.feed(ChannelState(0.0, 2, True))
    assert [str(v) for v in out] == ["on(m)"]


def test_observation_set_example_6_3() -> None:
    theta = ObservationSet()
    scan = Atom("ok", ("scan",))
    jaguar = Atom("running", ("jaguar_node",))
    cpu = Atom("ok", ("jyn", "cpu"))
    assert len(theta) == 0
    assert theta.add(Verdict(0.0, scan, True))
    assert theta.add(Verdict(0.1, jaguar, True))
    assert theta.add(Verdict(0.2, cpu, True))
    # The same observations again: Θ already holds them (line 1).
    assert not theta.add(Verdict(0.3, scan, True))
    assert not theta.add(Verdict(0.4, jaguar, True))
    assert not theta.add(Verdict(0.5, cpu, True))
    assert len(theta) == 3
    # jaguar_node stops: ¬running replaces running (lines 7-11).
    assert theta.add(Verdict(0.6, jaguar, False))
    assert [str(lit) for lit in theta.literals()] == [
        "not_running(jaguar_node)",
        "ok(jyn,cpu)",
        "ok(scan)",
    ]
    assert Literal(jaguar, False) in theta.literals()
    # An atom spelled with the prefix is the negation of the plain atom.
    assert not theta.add(Verdict(0.7, Atom("not_running", ("jaguar_node",)), True))
    assert theta.add(Verdict(0.8, Atom("not_running", ("jaguar_node",)), False))
    assert len(theta) == 3 and Literal(jaguar, True) in theta.literals()


def healthy_stream(bank: ObserverBank, duration: float, seed: int) -> list[Event]:
    """Messages at each GObs topic's rate (±5 % jitter), node and property samples at
    10 Hz under the limits, OK device statuses and powered channels."""
    rng = random.Random(seed)
    events: list[Event] = []
    fields = bank.topic_fields()
    rates = {o.topic: o.delta for o in bank.observers if isinstance(o, GObs)}
    for topic in fields:
        delta = rates.get(topic, 0.05)
        t = rng.uniform(0.0, delta)
        while t < duration:
            values = {f: math.sin(0.3 * t + len(f)) for f in fields[topic]}
            events.append(Message(t, topic, values))
            t += delta * rng.uniform(0.95, 1.05)
    limits = {(o.node, o.prop): o.max_val for o in bank.observers if isinstance(o, PObs)}
    for k in range(int(duration * 10)):
        t = k / 10
        events += [NodeSample(t, node, True) for node in sorted(bank.nodes)]
        events += [PropertySample(t, n, p, 0.5 * v) for (n, p), v in sorted(limits.items())]
        events += [DeviceStatus(t, d, "", 0) for d in sorted(bank.devices)]
        if bank.needs_board:
            events += [ChannelState(t, c, True) for c in range(1, 9)]
    events.sort(key=lambda e: e.t)
    return events


@pytest.mark.parametrize("model", ["tedusar.ram", "pioneer.ram"])
def test_models_observers_read_a_healthy_stream_as_healthy(model: str) -> None:
    observers = compile_model(load_model(str(MODELS / model))).observers
    bank = ObserverBank(observers)
    assert len(bank.observers) == len(observers)
    latest: dict[Atom, list[bool]] = {}
    for event in healthy_stream(bank, 12.0, seed=len(model)):
        for v in bank.advance(event.t) + bank.feed(event):
            latest.setdefault(v.atom, []).append(v.positive)
    watched = [o for o in observers if o.kind in ("GObs", "NObs", "PObs")]
    assert watched
    for spec in watched:
        assert latest.get(spec.atoms[0]) == [True], spec.name
    for spec in observers:
        if spec.kind in ("DObs", "HObs"):
            assert all(latest.get(a) == [True] for a in spec.atoms), spec.name


@pytest.mark.parametrize("model", ["tedusar.ram", "pioneer.ram"])
def test_bank_advances_only_the_observers_time_can_change(model: str) -> None:
    """A bank calls advance() only on the observers marked ``timed`` (replay calls it every
    0.1 s of a recording): on a stream that stops halfway, asking every observer as well
    finds no verdict the bank did not give, so no untimed observer has work in advance()."""
    observers = compile_model(load_model(str(MODELS / model))).observers
    bank = ObserverBank(observers)
    assert {type(o).__name__ for o in bank.observers if not o.timed} >= {"NObs", "PObs"}
    assert any(o.timed for o in bank.observers)
    events = [e for e in healthy_stream(bank, 20.0, seed=5) if e.t < 8.0 or e.t > 16.0]
    timed_verdicts = 0
    for event in events:
        timed_verdicts += len(bank.advance(event.t))
        untimed = [v for o in bank.observers if not o.timed for v in o.advance(event.t)]
        assert not untimed, (event.t, untimed)
        bank.feed(event)
    assert timed_verdicts  # the silence from 8 s to 16 s was noticed by advancing alone


def test_a_batch_of_messages_gives_each_observer_the_verdicts_of_one_message_at_a_time() -> None:
    """ObserverBank.feed_messages (a transport that reads what came on a connection in one
    pass) against feeding each message: per observer the same verdicts, through bursts,
    a stop, a restart with its stamps jumping back, a rate fault and a value relation."""
    rng = random.Random(36)
    model = compile_model(load_model(MODELS / "tedusar.ram"))
    one, batched = ObserverBank(model.observers), ObserverBank(model.observers)
    topics = sorted(one.topic_fields())
    fields = one.topic_fields()
    t, stamp = 0.0, 1000.0
    singles: list[Verdict] = []
    batches: list[Verdict] = []
    for step in range(3000):
        t += 0.05
        stamp = 900.0 if step == 1500 else stamp + 0.05  # a bag's loop starting over
        if 600 <= step < 700 or (step % 97 == 0):
            singles += one.advance(t)
            batches += batched.advance(t)
            continue  # every topic silent: a stop, and short pauses
        for topic in topics:
            count = rng.choice((0, 1, 2, 5, 8)) if step < 2200 else 12  # too fast at the end
            stamps = [stamp + 0.01 * k for k in range(count)]
            values = [{f: math.sin(t + k) for f in fields[topic]} for k in range(count)]
            for k in range(count):
                singles += one.feed(Message(t, topic, values[k], stamps[k]))
            batches += batched.feed_messages(t, topic, count, stamps, values)
        singles += one.advance(t)
        batches += batched.advance(t)

    def by_observer(verdicts: list[Verdict]) -> dict[Atom, list[tuple[float, bool]]]:
        out: dict[Atom, list[tuple[float, bool]]] = {}
        for v in verdicts:
            out.setdefault(v.atom, []).append((v.t, v.positive))
        return out

    assert by_observer(batches) == by_observer(singles)
    assert any(not v.positive for v in singles)  # the trace did flip verdicts
