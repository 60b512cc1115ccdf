"""derive_observers: the observers model (§5.2, §6.2.2, docs/spec.md).

One :class:`ObserverSpec` per observer instance, with the parameters the
dissertation's observer nodes take (names as in §6.2.2's launch file).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from rac.ir import FieldRef, Model, Topic
from rac.logic import Atom, mangle
from rac.passes.rbm import field_atom, ok

DEFAULT_WINDOW_OCCURRENCES = 10  # ω = c / freq with c = 10 (Equation 5.3)
DEFAULT_MISMATCH_THRESHOLD = 5
# A BiQObs checks every half window (0.5 s at ω = 1 s): three net mismatches are two seconds
# of trends that disagree, long enough to ride out a manoeuvre's change and short enough to
# see a slip that shows only while the robot drives straight (docs/observers.md).
BIQOBS_MISMATCH_THRESHOLD = 3
DEFAULT_PAIR_WINDOW_S = 1.0  # a related pair of two irregular topics
# The shortest trend window: a qualitative trend of a physical signal over less than a second
# is its noise, and θ checks (one per half window) would then last only a fraction of one.
MIN_PAIR_WINDOW_S = 1.0
DEFAULT_RATE_TOLERANCE = 0.1  # ±10 % of the rate when the model gives none
BOARD_TOPIC = "/board_measurements"
DIAGNOSTICS_TOPIC = "/diagnostics"

ParamValue = str | int | float  # bool is an int


@dataclass(frozen=True, slots=True)
class ObserverSpec:
    kind: str  # NObs, GObs, PObs, DObs, HObs, BiQObs, IObs
    name: str  # a valid ROS node name, unique in the model
    params: tuple[tuple[str, ParamValue], ...]
    atoms: tuple[Atom, ...]  # what it reports (each also negated)


@dataclass(frozen=True, slots=True)
class TopicSource:
    """Where an observed topic's messages may come from: its type as the model declares it
    (None: any) and the nodes that publish it (empty: the model names none, any counts).
    The observer host feeds its observers only from these (issue 34).  ``subscribers``: the
    nodes of the model that subscribe it, the only ones whose topic statistics (ROS 1's
    ``/statistics``) may stand for the topic's messages (docs/security.md)."""

    topic: str
    msg_type: str | None
    publishers: tuple[str, ...]
    subscribers: tuple[str, ...] = ()


def topic_sources(model: Model, observers: tuple[ObserverSpec, ...]) -> tuple[TopicSource, ...]:
    """The source of every topic an observer reads from a message, sorted by topic."""
    read = {
        str(value)
        for o in observers
        if o.kind in ("GObs", "BiQObs", "IObs")
        for key, value in o.params
        if key in ("topic", "topic1", "topic2")
    }
    publishers: dict[str, set[str]] = {}
    subscribers: dict[str, set[str]] = {}
    for node in model.nodes:
        for publication in node.publishes:
            publishers.setdefault(publication.topic.value, set()).add(node.name.value)
        for topic in node.subscribes:
            subscribers.setdefault(topic.value, set()).add(node.name.value)
    types = {t.name.value: t.msg_type for t in model.topics}
    return tuple(
        TopicSource(
            topic,
            types.get(topic),
            tuple(sorted(publishers.get(topic, ()))),
            tuple(sorted(subscribers.get(topic, ()))),
        )
        for topic in sorted(read)
    )


def gobs_timing(topic: Topic) -> tuple[float, float, float]:
    """δ = 1/rate, the interval deviation from the rate tolerance and ω, unrounded."""
    assert topic.rate_hz is not None
    rate = topic.rate_hz
    tolerance = topic.rate_tolerance_hz
    if tolerance is None:
        tolerance = DEFAULT_RATE_TOLERANCE * rate
    delta = 1.0 / rate
    # The slower edge of the band is the wider one in interval terms.
    dev = 1.0 / (rate - tolerance) - delta
    window = topic.window_s if topic.window_s is not None else DEFAULT_WINDOW_OCCURRENCES * delta
    return delta, dev, window


def gobs_params(topic: Topic) -> tuple[tuple[str, ParamValue], ...]:
    """δ = 1/rate, the interval deviation from the rate tolerance, ω, θ."""
    delta, dev, window = gobs_timing(topic)
    mismatch = topic.mismatch_threshold
    if mismatch is None:
        mismatch = DEFAULT_MISMATCH_THRESHOLD
    return (
        ("topic", topic.name.value),
        ("delta", _round(delta)),
        ("dev", _round(dev)),
        ("ws", _round(window)),
        ("mismatch_th", mismatch),
    )


def _round(value: float) -> float:
    # Twelve significant digits: exact enough, and free of float noise in the output.
    return float(f"{value:.12g}")


def derive_observers(model: Model) -> tuple[ObserverSpec, ...]:
    """Every observer instance the model calls for, grouped by kind."""
    specs: list[ObserverSpec] = []
    for node in model.nodes:
        n = mangle(node.name.value)
        specs.append(
            ObserverSpec(
                "NObs", f"{n}_nobs", (("node", node.name.value),), (Atom("running", (n,)),)
            )
        )
    for topic in model.topics:
        if topic.regular:
            t = mangle(topic.name.value)
            specs.append(
                ObserverSpec("GObs", f"{t}_gobs", gobs_params(topic), (ok(topic.name.value),))
            )
    for node in model.nodes:
        n = mangle(node.name.value)
        for prop, value in (("cpu", node.limits.cpu), ("mem", node.limits.mem)):
            if value is None:
                continue
            params: tuple[tuple[str, ParamValue], ...] = (
                ("node", node.name.value),
                ("property", prop),
                ("max_val", value),
                ("mismatch_th", DEFAULT_MISMATCH_THRESHOLD),
            )
            specs.append(
                ObserverSpec("PObs", f"{n}_{prop}_pobs", params, (ok(node.name.value, prop),))
            )
    # One DObs per reported device (docs/spec.md), naming every node that reports it.
    reporters: dict[str, list[str]] = {}
    for node in model.nodes:
        for device in node.diagnostics:
            reporters.setdefault(device.value, []).append(node.name.value)
    for device_name, nodes in reporters.items():
        params = (
            ("topic", DIAGNOSTICS_TOPIC),
            ("node", ",".join(nodes)),
            ("device", device_name),
        )
        d = mangle(device_name)
        specs.append(ObserverSpec("DObs", f"{d}_dobs", params, (ok(device_name),)))
    switchable = [h for h in model.hardware if h.switchable]
    if switchable:
        channels = ",".join(f"{h.name.value}:{h.channel}" for h in switchable)
        atoms = tuple(Atom("on", (mangle(h.name.value),)) for h in switchable)
        params = (("topic", BOARD_TOPIC), ("channels", channels))
        specs.append(ObserverSpec("HObs", "board_hobs", params, atoms))
    topics = model.topic_by_name()
    for i, rel in enumerate(model.related, start=1):
        params = biqobs_params(rel.a, rel.b, topics)
        atom = field_atom("matched", rel.a, rel.b)
        specs.append(ObserverSpec("BiQObs", f"biq{i}_biqobs", params, (atom,)))
    for i, iv in enumerate(model.intervals, start=1):
        params = (
            ("topic1", iv.a.topic),
            ("field1", iv.a.field),
            ("topic2", iv.b.topic),
            ("field2", iv.b.field),
            ("mismatch_th", DEFAULT_MISMATCH_THRESHOLD),
            ("max_diff", iv.max_diff),
        )
        atom = field_atom("equal", iv.a, iv.b)
        specs.append(ObserverSpec("IObs", f"interval{i}_iobs", params, (atom,)))
    return tuple(specs)


def biqobs_params(
    a: FieldRef, b: FieldRef, topics: Mapping[str, Topic]
) -> tuple[tuple[str, ParamValue], ...]:
    """Each side's topic, field and whether it is integrated, the regression window ws
    and θ.

    Both sides' trends come from one window so that they are comparable: ω = c / freq
    (Equation 5.3) of the slower regular topic, 1 s when neither topic has a rate, and
    never less than :data:`MIN_PAIR_WINDOW_S`.
    """
    rates = [
        t.rate_hz
        for t in (topics.get(a.topic), topics.get(b.topic))
        if t is not None and t.rate_hz is not None
    ]
    window = DEFAULT_WINDOW_OCCURRENCES / min(rates) if rates else DEFAULT_PAIR_WINDOW_S
    window = max(window, MIN_PAIR_WINDOW_S)
    return (
        ("topic1", a.topic),
        ("field1", a.field),
        ("integral1", a.integrated),
        ("topic2", b.topic),
        ("field2", b.field),
        ("integral2", b.integrated),
        ("ws", _round(window)),
        ("mismatch_th", BIQOBS_MISMATCH_THRESHOLD),
    )


def observable_atoms(observers: tuple[ObserverSpec, ...]) -> tuple[Atom, ...]:
    """``props`` of the model server file: every atom an observer can report."""
    return tuple(dict.fromkeys(a for o in observers for a in o.atoms))
