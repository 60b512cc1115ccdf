"""Learn a model from a recording (Algorithm 15) and assemble it as IR.

The structure comes from a base model (kept as it is), a computation graph, or the
recording alone; the learned parameters (rates, limits, related pairs) each carry a
comment with their evidence.  Algorithm 18 (the clauses) is the compiler's job: the
result is an ordinary model that ``compile_model`` turns into the diagnosis model.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from rac.ir import Hardware, Limits, Machine, Model, Name, Node, Publication, Related, Topic
from rac.learn import holdout
from rac.learn.correlate import Correlation, correlations
from rac.learn.fields import EULER_FIELDS
from rac.learn.frequency import RateStats, on_demand, rate_stats
from rac.learn.graph import Exclusions, Graph
from rac.learn.holdout import HeldOut
from rac.learn.options import LearnOptions
from rac.learn.properties import PropertyStats
from rac.learn.recording import Recording, TopicData
from rac.learn.relations import LearnedRelation, group_relations
from rac.learn.trends import Signal, TopicTrends, topic_trends
from rac.learn.validate import failures

STEADY_RATIO = 4.0  # Δ̄/σ(Δ) of a topic whose samples may be integrated by a running sum
# Limits' floors: an idle node's samples (0.01 % cpu, a flat memory use) would give a limit
# that any ordinary burst of work crosses.
# Topics the robot's nodes and racc's own runtime both publish on: the diagnosis engine and
# the repair engine publish their status on /diagnostics, which a recording made without
# racc does not hold, so a rate learned there reads "too fast" once racc runs.
SHARED_WITH_RACC = frozenset({"/diagnostics"})
CPU_FLOOR = 5.0  # % of one core
MEM_MARGIN = 1.2  # times the largest memory sample


@dataclass(frozen=True, slots=True)
class LearnResult:
    model: Model
    rates: tuple[RateStats, ...]
    relations: tuple[LearnedRelation, ...]
    properties: tuple[PropertyStats, ...]
    notes: tuple[str, ...]  # what the inputs could not give, for stderr
    options: LearnOptions = field(default_factory=LearnOptions)


def _sig(value: float, digits: int) -> float:
    return float(f"{value:.{digits}g}")


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:.4g} ms"


def _rounded_rate(rate: float, tolerance: float) -> tuple[float, float]:
    """The rate to the digits its tolerance justifies (a tenth of the tolerance's leading
    digit: 9.99997 ± 0.144 Hz is 10 Hz), the tolerance widened by what the rounding moved."""
    if not (math.isfinite(tolerance) and tolerance > 0):
        return _sig(rate, 6), _sig(tolerance, 3)
    step = 10.0 ** (math.floor(math.log10(tolerance)) - 1)
    rounded = _sig(round(rate / step) * step, 6) or _sig(rate, 6)  # never a rate of zero
    widened = tolerance + abs(rate - rounded)
    scale = 10.0 ** (math.floor(math.log10(widened)) - 2)
    return rounded, _sig(math.ceil(widened / scale - 1e-9) * scale, 3)


def _rate_comment(s: RateStats, alpha: float) -> str:
    verdict = f"> α {alpha:g}: regular" if s.regular else f"<= α {alpha:g}: irregular"
    return (
        f"learned from {s.samples} intervals: mean {_ms(s.mean)}, σ {_ms(s.stddev)}, "
        f"mean/σ {s.ratio:.3g} {verdict}"
    )


def _band(
    topic: Topic, data: TopicData, stats: RateStats, chosen: Sequence[holdout.Block]
) -> tuple[float, str]:
    """The learned rate tolerance: its slow edge lies the largest of σ, the held-out
    deviation with its margin, the floor and two lost messages beyond the mean interval;
    and its comment."""
    window = holdout.observer_window(stats.mean, topic.window_s)
    held = holdout.rate_holdout(data, chosen, window) if chosen else None
    floor = holdout.RATE_FLOOR * stats.mean
    lost = holdout.lost_messages(stats.mean, window)
    deviation = max(stats.stddev, floor, lost)
    text = (
        f"band: the largest of σ, {holdout.RATE_FLOOR:.0%} of the mean ({_ms(floor)}), "
        f"{holdout.LOST_MESSAGES} messages lost from the {window:.3g} s window ({_ms(lost)})"
    )
    if held is not None:
        deviation = max(deviation, holdout.RATE_MARGIN * held.deviation)
        text += (
            f" and {holdout.RATE_MARGIN:g} × the largest held-out deviation of the windowed "
            f"mean interval ({_ms(held.deviation)} over {held.blocks} blocks)"
        )
    return stats.rate_hz - 1.0 / (stats.mean + deviation), f"{text}: ±{_ms(deviation)}"


def _learned_topic(
    topic: Topic, stats: RateStats | None, alpha: float, band: tuple[float, str] | None = None
) -> Topic:
    """``topic`` with the learned rate and tolerance (or none) and the evidence comment."""
    if stats is None:
        note = "too few messages in the recording to learn a rate"
        return replace(topic, comments=(*topic.comments, note))
    comments = (*topic.comments, _rate_comment(stats, alpha))
    if stats.regular and band is not None:
        comments = (*comments, band[1])
    if not stats.regular:
        return replace(
            topic,
            rate_hz=None,
            rate_tolerance_hz=None,
            window_s=None,
            mismatch_threshold=None,
            comments=comments,
        )
    tolerance_hz = band[0] if band is not None else stats.tolerance_hz
    rate, tolerance = _rounded_rate(stats.rate_hz, tolerance_hz)
    tolerance = min(tolerance, rate * 0.999)
    window = topic.window_s if topic.rate_hz is not None else None
    mismatch = topic.mismatch_threshold if topic.rate_hz is not None else None
    return replace(
        topic,
        rate_hz=rate,
        rate_tolerance_hz=tolerance,
        window_s=window,
        mismatch_threshold=mismatch,
        comments=comments,
    )


def _limits(node: Node, stats: Sequence[PropertyStats], sigmas: float) -> Node:
    mine = {s.prop: s for s in stats if s.node == node.name.value}
    if not mine:
        return node
    cpu, mem = node.limits.cpu, node.limits.mem
    notes = []
    if "cpu" in mine:
        s = mine["cpu"]
        cpu = max(CPU_FLOOR, math.ceil(s.limit(sigmas) * 100) / 100)
        notes.append(f"cpu mean {s.mean:.3g} % σ {s.stddev:.3g} max {s.maximum:.3g} -> {cpu:g} %")
    if "mem" in mine:
        s = mine["mem"]
        mem = max(1000, math.ceil(max(s.limit(sigmas), MEM_MARGIN * s.maximum) / 1000) * 1000)
        notes.append(
            f"mem mean {s.mean / 1e6:.4g} MB σ {s.stddev / 1e6:.3g} MB max {s.maximum / 1e6:.4g} MB"
            f" -> {mem / 1e6:g} MB"
        )
    samples = max(s.samples for s in mine.values())
    comment = (
        f"learned limits from {samples} samples (mean + {sigmas:g}σ, at least the max; cpu at "
        f"least {CPU_FLOOR:g} %, mem at least {MEM_MARGIN:g} × the max): "
    )
    comment += "; ".join(notes)
    span = node.limits.span
    return replace(node, limits=Limits(cpu, mem, span), comments=(*node.comments, comment))


def _identifier(text: str) -> str:
    name = re.sub(r"[^A-Za-z0-9_\-]", "_", text).strip("_-") or "learned"
    return name if name[0].isalpha() or name[0] == "_" else f"r{name}"


def _structure_from_graph(graph: Graph) -> tuple[list[Node], list[Hardware]]:
    nodes = []
    placed = machines_from_graph(graph)[1]
    for g in sorted(graph.nodes, key=lambda n: n.name):
        subs = tuple(Name(t) for t in dict.fromkeys(g.subscriptions))
        pubs = tuple(
            Publication(Name(t), tuple(s for s in subs if s.value != t))
            for t in dict.fromkeys(g.publications)
        )
        where = Name(placed[g.name]) if g.name in placed else None
        nodes.append(
            Node(Name(g.name), tuple(Name(h) for h in g.drives), subs, pubs, machine=where)
        )
    declared = {h.name for h in graph.hardware}
    hardware = [Hardware(Name(h.name), h.switchable, h.channel) for h in graph.hardware]
    for h in sorted({d for g in graph.nodes for d in g.drives} - declared):
        hardware.append(Hardware(Name(h)))
    return nodes, hardware


def machines_from_graph(graph: Graph) -> tuple[tuple[Machine, ...], dict[str, str]]:
    """The machines of a graph whose nodes run on more than one host, and each node's
    machine (one host: nothing, the robot is one computer).  The host of most nodes comes
    first (a node without ``on`` runs there); a machine is named after its host."""
    hosts = [g.host for g in graph.nodes if g.host]
    if len(set(hosts)) < 2:
        return (), {}
    counts: dict[str, int] = {}
    for h in hosts:
        counts[h] = counts.get(h, 0) + 1
    ordered = sorted(counts, key=lambda h: (-counts[h], h))
    names: dict[str, str] = {}
    for host in ordered:
        base = re.sub(r"[^A-Za-z0-9_]", "_", host).strip("_") or "machine"
        base = base if base[0].isalpha() else f"host_{base}"
        name, i = base, 2
        while name in names.values():
            name, i = f"{base}_{i}", i + 1
        names[host] = name
    machines = tuple(Machine(Name(names[h]), address=h) for h in ordered)
    return machines, {g.name: names[g.host] for g in graph.nodes if g.host}


def _structure_from_recording(recording: Recording) -> list[Node]:
    published: dict[str, list[str]] = {}
    for t in recording.topics:
        for n in t.publishers:
            published.setdefault(n, []).append(t.name)
    return [
        Node(Name(n), publishes=tuple(Publication(Name(t)) for t in sorted(ts)))
        for n, ts in sorted(published.items())
    ]


def _why_no_publishers(recording: Recording) -> str:
    """Why a recording names no publishing node, by the ROS version of its runs."""
    versions = {r.ros_version for r in recording.runs}
    ros2 = "ROS 2 bags do not record them"
    ros1 = (
        "its ROS 1 connections carry no callerid: the bag was written by a converter or a "
        "library, not by rosbag record"
    )
    if versions == {2}:
        return ros2
    if versions == {1}:
        return ros1
    return f"{ros2}, and {ros1.removeprefix('its ')}"


def _topic_from_recording(data: TopicData) -> Topic:
    """The recorded topic with its varying fields: a constant signal relates to nothing."""
    return Topic(Name(data.name), data.msg_type, tuple(Name(f) for f in varying_fields(data)))


def varying_fields(data: TopicData) -> tuple[str, ...]:
    """The fields whose finite values change over the recording."""
    out = []
    for name, row in zip(data.fields, data.values, strict=True):
        finite = row[np.isfinite(row)]
        if finite.size and float(finite.max()) > float(finite.min()):
            out.append(name)
    return tuple(out)


def _without_tools(
    recording: Recording, graph: Graph | None, exclusions: Exclusions, notes: list[str]
) -> tuple[Recording, Graph | None]:
    """The recording and graph without racc's own topics and nodes and ROS's tool nodes
    (a recording made while racc or ``rostopic echo`` ran holds them)."""
    topics = []
    left_out: set[str] = set()
    for t in recording.topics:
        owners = [f"/{p}" for p in t.publishers]
        if not exclusions.topic(t.name, owners):
            left_out.add(t.name)
            continue
        mine = tuple(p for p in t.publishers if exclusions.node(p))
        left_out.update(f"/{p}" for p in t.publishers if p not in mine)
        topics.append(replace(t, publishers=mine) if mine != t.publishers else t)
    if graph is not None:
        kept_nodes = []
        for g in graph.nodes:
            if not exclusions.node(g.name):
                left_out.add(f"/{g.name}")
                continue
            pubs = tuple(t for t in g.publications if exclusions.topic(t))
            subs = tuple(t for t in g.subscriptions if exclusions.topic(t))
            left_out.update(set(g.publications + g.subscriptions) - set(pubs + subs))
            kept_nodes.append(replace(g, publications=pubs, subscriptions=subs))
        graph = replace(graph, nodes=tuple(kept_nodes))
    if left_out:
        notes.append(
            "racc's own and ROS's tool topics and nodes left out (--include keeps them): "
            + ", ".join(sorted(left_out))
        )
    return replace(recording, topics=tuple(topics)), graph


def _structure(
    recording: Recording, base: Model | None, graph: Graph | None, notes: list[str]
) -> tuple[list[Node], list[Hardware], list[Topic]]:
    """Nodes, hardware and declared topics (Definition 9.2), from the best source given."""
    recorded = recording.topic_by_name()
    if base is not None:
        declared = {t.name.value for t in base.topics}
        ignored = sorted((set(recorded) | set(recording.skipped)) - declared)
        if ignored:
            notes.append(f"recorded topics not in the base model, ignored: {', '.join(ignored)}")
        return list(base.nodes), list(base.hardware), list(base.topics)
    if graph is not None:
        nodes, hardware = _structure_from_graph(graph)
    else:
        nodes, hardware = _structure_from_recording(recording), []
        notes.append(
            "no --base or --graph: subscriptions, hardware and drivers are not in a "
            "recording, so the model has none (give --base robot.ram or --graph graph.yaml)"
        )
        if not nodes:
            notes.append(
                f"the recording names no publishers ({_why_no_publishers(recording)}): the "
                "model has no nodes, so no rates or relations can be declared; they are in "
                "comments"
            )
    topics = [_topic_from_recording(recorded[n]) for n in sorted(recorded)]
    known = set(recorded)
    for node in nodes:
        for t in [*(s.value for s in node.subscribes), *node.published_topics]:
            if t not in known:
                known.add(t)
                topics.append(Topic(Name(t), comments=("not in the recording",)))
                notes.append(f"graph topic {t} is not in the recording: no rate learned")
    return nodes, hardware, topics


def _learn_rates(
    topics: list[Topic],
    recording: Recording,
    published: set[str],
    options: LearnOptions,
    notes: list[str],
    undeclared: list[str],
) -> tuple[list[Topic], list[RateStats]]:
    """Frequency observers (Algorithm 15, lines 5-10) on the declared topics."""
    recorded = recording.topic_by_name()
    rates: list[RateStats] = []
    learned_topics: list[Topic] = []
    chosen = holdout.blocks(recording, options.blocks)
    for topic in topics:
        data = recorded.get(topic.name.value)
        if data is None:
            if topic.rate_hz is not None or topic.fields:
                notes.append(f"topic {topic.name.value} is not in the recording: kept as it was")
            learned_topics.append(topic)
            continue
        stats = rate_stats(data, options.alpha)
        if stats is not None:
            rates.append(stats)
        if topic.name.value in SHARED_WITH_RACC:
            why = (
                f"no rate learned: racc's own nodes publish on {topic.name.value} too, so on "
                "the robot with racc running its rate is not the recorded one"
            )
            notes.append(f"topic {topic.name.value}: {why}")
            learned_topics.append(replace(topic, comments=(*topic.comments, why)))
            continue
        band = _band(topic, data, stats, chosen) if stats is not None and stats.regular else None
        learned = _learned_topic(topic, stats, options.alpha, band)
        if learned.rate_hz is not None and topic.name.value not in published:
            # Only a published topic can be declared regular: ok(t) needs a clause.
            undeclared.append(
                f"{topic.name.value} @ {learned.rate_hz:g} Hz +- "
                f"{learned.rate_tolerance_hz:g} Hz (no publisher known, so not declared)"
            )
            learned = replace(
                learned,
                rate_hz=None,
                rate_tolerance_hz=None,
                window_s=None,
                mismatch_threshold=None,
            )
        looks = on_demand(topic.name.value, topic.msg_type or data.msg_type)
        if learned.rate_hz is not None and looks is not None:
            why = (
                f"the rate is learned, but {topic.name.value} looks published on demand "
                f"({looks}): its frequency observer reports a fault whenever the publisher "
                "is not asked to publish; keep the rate only if it publishes all the time"
            )
            notes.append(f"topic {topic.name.value}: {why}")
            learned = replace(learned, comments=(*learned.comments, why))
        learned_topics.append(learned)
    return learned_topics, rates


def _learn_relations(
    recording: Recording,
    options: LearnOptions,
    declared: set[str],
    declarable: set[str],
    undeclared: list[str],
    regular: set[str],
    notes: list[str],
    flow: set[frozenset[str]],
) -> tuple[list[Related], list[LearnedRelation], list[str]]:
    """Qualitative correlations (Algorithms 16 and 17) between the declared topics, as
    ``relate`` declarations where both topics have a publisher; held out on blocks of the
    recording (:mod:`rac.learn.holdout`) unless ``options.blocks`` is 0.  Also the
    comments naming the candidates held-out validation rejected."""
    trends = []
    for data in (t for t in recording.topics if t.name in declared):
        topic_trend = topic_trends(candidate_signals(data), options.occurrences, options.integrate)
        if topic_trend is not None:
            trends.append(topic_trend)
    if len({s for t in trends for s in t.signals if not s.integrated}) < 2:
        notes.append(
            "no two varying numeric signals are left to relate, so no relations are learned "
            "(are the topics' fields constant, or excluded by the base model's field lists?)"
        )
    found = correlations(trends, options.q, options.min_lift)
    held: dict[tuple[Signal, Signal], HeldOut] = {}
    rejected: list[str] = []
    chosen = holdout.blocks(recording, options.blocks)
    if found and chosen:
        found, held, rejected = _held_out(recording, trends, found, chosen, options, flow)
        if rejected:
            notes.append(
                f"{len(rejected)} candidate relations did not hold on held-out blocks of the "
                f"recording ({len(chosen)} blocks), not kept: the end of the model says why"
            )
    elif found and options.blocks:
        notes.append(
            "the recording is too short to cut into blocks: relations are not held out "
            f"(blocks of at least {holdout.MIN_BLOCK_S:g} s are needed)"
        )
    related: list[Related] = []
    kept: list[LearnedRelation] = []
    for rel in group_relations(found):
        if not {rel.a[0], rel.b[0]} <= declarable:
            undeclared.append(
                f"{rel.declaration()}: {rel.evidence()} (a topic has no known publisher)"
            )
            continue
        # A pair that only matched with one side integrated is declared with I() on that
        # side: its observer integrates it, so it reads "matched" on a healthy robot.
        sides = rel.sides()
        if any(s.integrated and s.topic not in regular for s in sides):
            # A running sum of samples follows the integral only at a steady rate.
            undeclared.append(
                f"{rel.declaration()}: {rel.evidence()} (integrates a topic without a "
                "steady rate, whose running sum does not follow the integral)"
            )
            continue
        evidence = [rel.evidence()]
        verdict = held.get((rel.best.a, rel.best.b))
        if verdict is not None:
            evidence.append(verdict.comment())
        related.append(Related(*sides, comments=tuple(evidence)))
        kept.append(rel)
    return related, kept, rejected


def candidate_signals(data: TopicData) -> TopicData:
    """``data`` without the raw components of an orientation quaternion when its derived
    angles are there: a component's trend depends on the heading (cos(yaw/2) rises in one
    half turn and falls in the other), the angles' do not."""
    if not set(EULER_FIELDS) & set(data.fields):
        return data
    drop = {f for f in data.fields if quaternion_component(f)}
    if not drop:
        return data
    rows = [i for i, f in enumerate(data.fields) if f not in drop]
    return replace(data, fields=tuple(data.fields[i] for i in rows), values=data.values[rows])


def quaternion_component(field_name: str) -> bool:
    """``orientation.w``, ``pose.pose.orientation.z``, …: a component of an orientation."""
    prefix, _, last = field_name.rpartition(".")
    return last in ("x", "y", "z", "w") and prefix.rsplit(".", 1)[-1] == "orientation"


def _held_out(
    recording: Recording,
    trends: Sequence[TopicTrends],
    found: list[Correlation],
    chosen: Sequence[holdout.Block],
    options: LearnOptions,
    flow: set[frozenset[str]],
) -> tuple[list[Correlation], dict[tuple[Signal, Signal], HeldOut], list[str]]:
    """The correlations that hold on blocks they were not fitted on, their verdicts, and
    a comment per rejected one."""
    pairs = [(c.a, c.b) for c in found]
    evidence = holdout.block_evidence(
        recording, chosen, pairs, options.occurrences, options.integrate
    )
    raw = [
        holdout.held_out(evidence, i, options.q, options.min_lift, options.significance)
        for i in range(len(found))
    ]
    verdicts = _corrected(found, raw, trends, flow, options)
    by_topic = {t.topic: t for t in trends}
    ranges = holdout.heading_quadrants(recording)
    kept: list[Correlation] = []
    held: dict[tuple[Signal, Signal], HeldOut] = {}
    rejected: list[str] = []
    for c, v in zip(found, verdicts, strict=True):
        why = v.why_not or holdout.range_dependence(c, by_topic, ranges, options.min_lift)
        if why:
            rejected.append(f"not kept: {c.a.text} ~ {c.b.text} ({c.ratio:.2f}): {why}")
            continue
        kept.append(c)
        held[(c.a, c.b)] = v
    return kept, held, rejected


def _corrected(
    found: Sequence[Correlation],
    raw: Sequence[HeldOut],
    trends: Sequence[TopicTrends],
    flow: set[frozenset[str]],
    options: LearnOptions,
) -> list[HeldOut]:
    """Holm's correction, in two tiers unless ``options.all_pairs``: the physically
    plausible pairs (:func:`plausible`) against the number of plausible pairs tried, the
    others against the number of all pairs tried."""
    if options.all_pairs:
        return holdout.with_holm(raw, tried_pairs(trends), options.significance)
    tiers = [plausible(c.a, c.b, flow) for c in found]
    out: list[HeldOut | None] = [None] * len(found)
    for tier, family in ((True, plausible_pairs(trends, flow)), (False, tried_pairs(trends))):
        chosen = [i for i, t in enumerate(tiers) if t is tier]
        corrected = holdout.with_holm([raw[i] for i in chosen], family, options.significance)
        for i, v in zip(chosen, corrected, strict=True):
            out[i] = v
    return [v for v in out if v is not None]


_AXES = {"yaw": "z", "pitch": "y", "roll": "x"}


def _leaf(field_name: str) -> str:
    """The quantity a field names: its last two path components (``linear.x``)."""
    return ".".join(field_name.split(".")[-2:])


def _rate_axis(signal: Signal) -> str | None:
    """The axis of an integrated angular rate (``I(angular_velocity.z)``: z)."""
    parts = signal.field.split(".")
    if signal.integrated and len(parts) >= 2 and parts[-2].startswith("angular"):
        return parts[-1]
    return None


def plausible(a: Signal, b: Signal, flow: set[frozenset[str]]) -> bool:
    """A pair worth trying first: its topics lie along the data flow (one feeds the
    other's publisher, or one node publishes both), or it pairs the same quantity (yaw with
    yaw, ``linear.x`` with ``linear.x``, an angle with its integrated rate)."""
    if a.topic != b.topic and frozenset((a.topic, b.topic)) in flow:
        return True
    if not a.integrated and not b.integrated:
        return _leaf(a.field) == _leaf(b.field)
    for angle, rate in ((a, b), (b, a)):
        axis = _rate_axis(rate)
        if axis is not None and not angle.integrated and _AXES.get(angle.field) == axis:
            return True
    return False


def data_flow(nodes: Sequence[Node]) -> set[frozenset[str]]:
    """Topic pairs along the data flow: an input with the publication it affects (all the
    node's subscriptions when the publication names none), and two publications of one
    node."""
    out: set[frozenset[str]] = set()
    for node in nodes:
        published = [p.topic.value for p in node.publishes]
        for p in node.publishes:
            inputs = p.affected_by or node.subscribes
            out.update(frozenset((i.value, p.topic.value)) for i in inputs)
        out.update(frozenset((x, y)) for x in published for y in published if x != y)
    return out


def plausible_pairs(trends: Sequence[TopicTrends], flow: set[frozenset[str]]) -> int:
    """How many plausible pairs the search tries, counted generously (a pair both along
    the flow and of one quantity counts twice), so that the correction stays on the safe
    side."""
    raw = {t.topic: sum(1 for s in t.signals if not s.integrated) for t in trends}
    integrated = {t.topic: sum(1 for s in t.signals if s.integrated) for t in trends}
    count = 0
    names = sorted(raw)
    for i, x in enumerate(names):
        for y in names[i + 1 :]:
            if frozenset((x, y)) in flow:
                count += raw[x] * raw[y] + raw[x] * integrated[y] + integrated[x] * raw[y]
    leaves: dict[str, int] = {}
    angles: dict[str, int] = {}
    rates: dict[str, int] = {}
    for t in trends:
        for sig in t.signals:
            if not sig.integrated:
                leaves[_leaf(sig.field)] = leaves.get(_leaf(sig.field), 0) + 1
                if sig.field in _AXES:
                    angles[_AXES[sig.field]] = angles.get(_AXES[sig.field], 0) + 1
            elif (axis := _rate_axis(sig)) is not None:
                rates[axis] = rates.get(axis, 0) + 1
    count += sum(n * (n - 1) // 2 for n in leaves.values())
    count += sum(n * rates.get(axis, 0) for axis, n in angles.items())
    return max(count, 1)


def tried_pairs(trends: Sequence[TopicTrends]) -> int:
    """How many signal pairs the search tries (the family Holm's correction counts)."""
    raw = sum(sum(1 for s in t.signals if not s.integrated) for t in trends)
    integrated = sum(sum(1 for s in t.signals if s.integrated) for t in trends)
    # Both raw, or one side integrated: never both.
    return raw * (raw - 1) // 2 + raw * integrated


def _robot_name(recording: Recording, base: Model | None, options: LearnOptions) -> str:
    if base is not None:
        return base.name.value
    if options.name:
        return options.name
    first = recording.runs[0].path.rstrip("/").rsplit("/", 1)[-1]
    return _identifier(re.sub(r"\.bag$", "", first))


def learn(
    recording: Recording,
    options: LearnOptions,
    *,
    base: Model | None = None,
    graph: Graph | None = None,
    properties: Sequence[PropertyStats] = (),
) -> LearnResult:
    """Algorithm 15 over a merged recording; the structure from ``base``, ``graph`` or it."""
    notes: list[str] = []
    undeclared: list[str] = []  # learned, but not declarable for want of a publisher
    if base is None:
        recording, graph = _without_tools(recording, graph, Exclusions(options.include), notes)
    nodes, hardware, topics = _structure(recording, base, graph, notes)
    published = {t for n in nodes for t in n.published_topics}
    learned_topics, rates = _learn_rates(topics, recording, published, options, notes, undeclared)
    # Property observers (Algorithm 15, lines 11-14).
    stray = sorted({s.node for s in properties} - {n.name.value for n in nodes})
    if stray:
        notes.append(f"property samples of nodes not in the model, ignored: {', '.join(stray)}")
    nodes = [_limits(n, properties, options.sigmas) for n in nodes]
    declared = {t.name.value for t in learned_topics}
    # I() needs a steady rate whatever α says: a running sum of samples follows the
    # integral only when the samples come evenly.
    steady = {r.topic for r in rates if r.ratio >= STEADY_RATIO}
    regular = {t.name.value for t in learned_topics if t.regular} & steady
    related, kept, rejected = _learn_relations(
        recording,
        options,
        declared,
        published & declared,
        undeclared,
        regular,
        notes,
        data_flow(nodes),
    )
    if base is not None:
        _note_dropped_relations(base, related, options, notes)
    needed: dict[str, list[str]] = {}
    for r in related:
        for ref in (r.a, r.b):
            needed.setdefault(ref.topic, []).append(ref.field)
    learned_topics = [_with_fields(t, needed.get(t.name.value, [])) for t in learned_topics]
    header = [
        f"Learned by racc learn from {len(recording.runs)} run(s), {recording.messages} messages: "
        + ", ".join(r.path for r in recording.runs),
        f"α {options.alpha:g}, Q {options.q:g}, C {options.occurrences}; "
        "review every learned value before use.",
    ]
    trailing = ["learned but not declared:", *undeclared] if undeclared else []
    trailing += rejected
    model = Model(
        name=Name(_robot_name(recording, base, options)),
        hardware=tuple(hardware),
        topics=tuple(learned_topics),
        nodes=tuple(nodes),
        related=tuple(related),
        intervals=base.intervals if base is not None else (),
        machines=(
            base.machines
            if base is not None
            else machines_from_graph(graph)[0]
            if graph is not None
            else ()
        ),
        comments=(*header, *(base.comments if base is not None else ())),
        trailing_comments=tuple(trailing),
    )
    if options.validate:
        # Dropping a rate changes the windows of the relations on that topic: check again
        # then (a model whose rates all held is checked once).
        for _ in range(3):
            checked = _without_false_alarms(model, recording, notes)
            rates_kept = [t.rate_hz for t in checked.topics] == [t.rate_hz for t in model.topics]
            model = checked
            if rates_kept:
                break
    return LearnResult(model, tuple(rates), tuple(kept), tuple(properties), tuple(notes), options)


def _without_false_alarms(model: Model, recording: Recording, notes: list[str]) -> Model:
    """Drop the learned rates and relations whose observers report a fault on the
    fault-free training runs themselves (:mod:`rac.learn.validate`)."""
    failed = failures(model, recording)
    if not failed:
        return model
    topics = list(model.topics)
    dropped: list[str] = []
    bad_relations = set()
    for f in failed:
        where = f"{f.run} at {f.at:.1f} s"
        if f.kind == "GObs":
            t = topics[f.index]
            why = f"rate {t.rate_hz:g} Hz dropped: its frequency observer read not ok on {where}"
            topics[f.index] = replace(
                t,
                rate_hz=None,
                rate_tolerance_hz=None,
                window_s=None,
                mismatch_threshold=None,
                comments=(*t.comments, why),
            )
            dropped.append(f"{t.name.value} @ {t.rate_hz:g} Hz")
        else:
            r = model.related[f.index]
            bad_relations.add(f.index)
            dropped.append(f"{r.a.text} ~ {r.b.text}")
    related = tuple(r for i, r in enumerate(model.related) if i not in bad_relations)
    trailing = [
        f"dropped: relate {model.related[f.index].a.text} ~ {model.related[f.index].b.text} "
        f"(its observer {'came near' if f.near else 'read'} not matched on {f.run} at "
        f"{f.at:.1f} s)"
        for f in failed
        if f.kind == "BiQObs"
    ]
    notes.append(
        "observers that report a fault on the training runs themselves, dropped: "
        + "; ".join(dropped)
    )
    return replace(
        model,
        topics=tuple(topics),
        related=related,
        trailing_comments=(*model.trailing_comments, *trailing),
    )


def _note_dropped_relations(
    base: Model, related: Sequence[Related], options: LearnOptions, notes: list[str]
) -> None:
    """A base model's ``relate`` lines are replaced by the learned ones: say which went."""
    found = {frozenset((r.a.text, r.b.text)) for r in related}
    dropped = [
        f"{r.a.text} ~ {r.b.text}"
        for r in base.related
        if frozenset((r.a.text, r.b.text)) not in found
    ]
    if dropped:
        notes.append(
            f"relations of the base model not found in the recording at Q {options.q:g}, "
            f"dropped: {'; '.join(dropped)}"
        )


def _with_fields(topic: Topic, needed: list[str]) -> Topic:
    have = [f.value for f in topic.fields]
    extra = sorted(set(needed) - set(have))
    if not extra:
        return topic
    return replace(topic, fields=(*topic.fields, *(Name(f) for f in extra)))


def observer_counts(model: Model) -> dict[str, int]:
    """Observers per kind as Table 10.1 counts them."""
    counts = {
        "BiQObs": len(model.related),
        "GObs": sum(1 for t in model.topics if t.regular),
        "NObs": len(model.nodes),
        "PObs_cpu": sum(1 for n in model.nodes if n.limits.cpu is not None),
        "PObs_mem": sum(1 for n in model.nodes if n.limits.mem is not None),
    }
    counts["total"] = sum(counts.values())
    return counts


def report(result: LearnResult) -> dict[str, Any]:
    """The ``--report`` JSON: parameters, counts per observer kind (Table 10.1), evidence."""
    o = result.options
    regular = {t.name.value: t for t in result.model.topics if t.regular}
    return {
        "format": "racc-learn-report/1",
        "robot": result.model.name.value,
        "parameters": {
            "alpha": o.alpha,
            "Q": o.q,
            "occurrences": o.occurrences,
            "min_lift": o.min_lift,
            "sigmas": o.sigmas,
        },
        "observers": observer_counts(result.model),
        "topics": [
            {
                "topic": s.topic,
                "intervals": s.samples,
                "mean_interval_s": s.mean,
                "stddev_s": s.stddev,
                "ratio": s.ratio if math.isfinite(s.ratio) else None,
                "regular": s.topic in regular,
                "rate_hz": regular[s.topic].rate_hz if s.topic in regular else None,
                "tolerance_hz": regular[s.topic].rate_tolerance_hz if s.topic in regular else None,
            }
            for s in result.rates
        ],
        "related": [
            {
                "a": f"{r.a[0]}.{r.a[1]}",
                "b": f"{r.b[0]}.{r.b[1]}",
                "integrated_only": r.integrated,
                "variants": [
                    {
                        "a": v.a.text,
                        "b": v.b.text,
                        "ratio": v.ratio,
                        "matches": v.matches,
                        "checks": v.checks,
                    }
                    for v in r.variants
                ],
            }
            for r in result.relations
        ],
        "properties": [
            {
                "node": p.node,
                "property": p.prop,
                "samples": p.samples,
                "mean": p.mean,
                "stddev": p.stddev,
                "max": p.maximum,
            }
            for p in result.properties
        ],
        "notes": list(result.notes),
    }
