"""Learn a model from recordings (Algorithm 15) and assemble it as IR.

The structure comes from a base model (kept as it is), a computation graph, or the
recording alone (:mod:`rac.learn.structure`); the learned parameters each carry a comment
with their evidence: rates (:mod:`rac.learn.rates`), limits (:mod:`rac.learn.limits`) and
relations (:mod:`rac.learn.select`).  Each recording is summarised on its own into
statistics that merge (:mod:`rac.learn.summary`), through ``mapper``, which may spread them
over processes.  Algorithm 18 (the clauses) is the compiler's job: the result is an
ordinary model that ``compile_model`` turns into the diagnosis model.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from rac.ir import Model, Name, Related, Topic
from rac.learn.frequency import RateStats
from rac.learn.graph import Exclusions, Graph
from rac.learn.limits import learned_limits
from rac.learn.options import LearnOptions
from rac.learn.properties import PropertyStats
from rac.learn.rates import learn_rates
from rac.learn.recording import Recording
from rac.learn.relations import Judged, LearnedRelation
from rac.learn.report import observer_counts, report
from rac.learn.select import learn_relations
from rac.learn.structure import (
    excluded,
    machines_from_graph,
    robot_name,
    structure,
    without_tools,
)
from rac.learn.summary import Mapper, RateSummary, merge_all, segments, serial, summarize_rates
from rac.learn.validate import without_false_alarms

STEADY_RATIO = 4.0  # median/σ of the intervals of a topic whose samples may be integrated

__all__ = ["STEADY_RATIO", "LearnResult", "learn", "observer_counts", "report"]


@dataclass(frozen=True, slots=True)
class LearnResult:
    model: Model
    rates: tuple[RateStats, ...]
    relations: tuple[LearnedRelation, ...]
    properties: tuple[PropertyStats, ...]
    notes: tuple[str, ...]  # what the inputs could not give, for stderr
    options: LearnOptions = field(default_factory=LearnOptions)
    judged: tuple[Judged, ...] = ()  # every candidate relation with its verdict
    unstable: int = 0  # candidates whose verdict changed between the two splits
    seconds: tuple[tuple[str, float], ...] = ()  # (phase, seconds) of the learning


def rate_summary(
    recording: Recording, options: LearnOptions, topics: Sequence[Topic], mapper: Mapper = serial
) -> RateSummary:
    """The timing of every topic of every run, summarised run by run and merged."""
    windows = {t.name.value: t.window_s for t in topics}

    def one(segment: int) -> object:
        return summarize_rates(recording, segment, options.blocks, windows)

    found = [s for s in mapper(one, segments(recording)) if isinstance(s, RateSummary)]
    return merge_all(found) if found else RateSummary(())


def learn(
    recording: Recording,
    options: LearnOptions,
    *,
    base: Model | None = None,
    graph: Graph | None = None,
    properties: Sequence[PropertyStats] = (),
    mapper: Mapper = serial,
) -> LearnResult:
    """Algorithm 15 over recorded runs; the structure from ``base``, ``graph`` or them."""
    notes: list[str] = []
    undeclared: list[str] = []  # learned, but not declarable for want of a publisher
    clock = [time.perf_counter()]
    seconds: list[tuple[str, float]] = []

    def lap(phase: str) -> None:
        now = time.perf_counter()
        seconds.append((phase, now - clock[0]))
        clock[0] = now

    if base is None:
        recording, graph = without_tools(recording, graph, Exclusions(options.include), notes)
    recording, graph = excluded(recording, graph, options.exclude, notes)
    nodes, hardware, topics = structure(recording, base, graph, notes)
    published = {t for n in nodes for t in n.published_topics}
    timing = rate_summary(recording, options, topics, mapper)
    learned_topics, rates = learn_rates(
        topics, timing.topics, published, options, notes, undeclared
    )
    lap("rates_s")
    # Property observers (Algorithm 15, lines 11-14).
    stray = sorted({s.node for s in properties} - {n.name.value for n in nodes})
    if stray:
        notes.append(f"property samples of nodes not in the model, ignored: {', '.join(stray)}")
    nodes = [learned_limits(n, properties, options.sigmas) for n in nodes]
    declared = {t.name.value for t in learned_topics}
    # I() needs a steady rate whatever α says: a running sum of samples follows the
    # integral only when the samples come evenly.
    regular = {t.name.value for t in learned_topics if t.regular}
    steady = {r.topic for r in rates if r.ratio >= STEADY_RATIO and r.topic in regular}
    relations = learn_relations(
        recording,
        options,
        declared,
        published & declared,
        steady if options.integrate else set(),
        nodes,
        notes,
        undeclared,
        mapper,
    )
    lap("relations_s")
    if base is not None:
        _note_dropped_relations(base, relations.related, options, notes)
    needed: dict[str, list[str]] = {}
    for r in relations.related:
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
    trailing += relations.rejected
    model = Model(
        name=Name(robot_name(recording, base, options)),
        hardware=tuple(hardware),
        topics=tuple(learned_topics),
        nodes=tuple(nodes),
        related=relations.related,
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
            checked = without_false_alarms(model, recording, notes, mapper)
            rates_kept = [t.rate_hz for t in checked.topics] == [t.rate_hz for t in model.topics]
            model = checked
            if rates_kept:
                break
    lap("check_s")
    kept = {(r.a.text, r.b.text) for r in model.related}
    learned = tuple(rel for rel in relations.kept if _declared(rel) in kept)
    return LearnResult(
        model,
        tuple(rates),
        learned,
        tuple(properties),
        tuple(notes),
        options,
        relations.judged,
        relations.unstable,
        tuple(seconds),
    )


def _declared(rel: LearnedRelation) -> tuple[str, str]:
    a, b = rel.sides()
    return a.text, b.text


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
