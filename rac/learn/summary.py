"""What one recording contributes to learning, as values that merge.

Learning reads many recordings (days of one robot, robots of one fleet).  Each recording is
summarised on its own, in parallel, into statistics that do not need the recording any
more and that add up across recordings: the timing of each topic per block
(:class:`~rac.learn.frequency.TopicRates`, histograms and extremes) and the agreement of
each candidate pair per block (:class:`~rac.learn.correlate.PairEvidence`, counts and
variances), with its agreement per heading quadrant.  :meth:`RateSummary.merged` and
:meth:`RelationSummary.merged` combine two summaries into the summary of both recordings,
so that the recordings of an archive can be summarised where they lie and only the
summaries brought together.

Summaries come in two passes because the candidates depend on the rates (a side is
integrated only on a topic published at a steady rate): first the rates of every
recording, then, with the candidates they allow, the relations.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from rac.learn.correlate import Heading, PairEvidence, Quadrants, TrendSet
from rac.learn.frequency import TopicRates, topic_rates
from rac.learn.holdout import Block, block_topic, run_blocks, splits
from rac.learn.recording import Recording, TopicData
from rac.learn.trends import Signal, TopicTrends, scales_of, topic_trends

Pair = tuple[Signal, Signal]
BlockEvidence = Mapping[Pair, PairEvidence]
Mapper = Callable[[Callable[[int], object], Sequence[int]], list[object]]


def serial(fn: Callable[[int], object], items: Sequence[int]) -> list[object]:
    """The default way of mapping over recordings: one after another."""
    return [fn(i) for i in items]


@dataclass(frozen=True, slots=True)
class RateSummary:
    """The timing of every topic, per block, of one or more recordings."""

    runs: tuple[str, ...]
    topics: Mapping[str, TopicRates] = field(default_factory=dict)

    def merged(self, other: RateSummary) -> RateSummary:
        topics = dict(self.topics)
        for name, rates in other.topics.items():
            topics[name] = topics[name].merged(rates) if name in topics else rates
        return RateSummary(self.runs + other.runs, topics)


@dataclass(frozen=True, slots=True)
class RelationSummary:
    """The agreement of every candidate pair, per block of each split, of one or more
    recordings; and per heading quadrant."""

    runs: tuple[str, ...]
    splits: tuple[tuple[BlockEvidence, ...], ...]  # per split, its blocks
    quadrants: Mapping[Pair, Quadrants] = field(default_factory=dict)

    def merged(self, other: RelationSummary) -> RelationSummary:
        width = max(len(self.splits), len(other.splits))
        joined = tuple(
            (self.splits[i] if i < len(self.splits) else ())
            + (other.splits[i] if i < len(other.splits) else ())
            for i in range(width)
        )
        quads = dict(self.quadrants)
        for pair, q in other.quadrants.items():
            quads[pair] = quads[pair] + q if pair in quads else q
        return RelationSummary(self.runs + other.runs, joined, quads)

    def evidence(self, split: int, pair: Pair) -> list[PairEvidence | None]:
        return [block.get(pair) for block in self.splits[split]]


def merge_all(summaries: Sequence[RateSummary]) -> RateSummary:
    out = summaries[0]
    for s in summaries[1:]:
        out = out.merged(s)
    return out


def merge_relations(summaries: Sequence[RelationSummary]) -> RelationSummary:
    out = summaries[0]
    for s in summaries[1:]:
        out = out.merged(s)
    return out


def summarize_rates(
    recording: Recording, segment: int, blocks: int, windows: Mapping[str, float | None]
) -> RateSummary:
    """One run's timing: every topic on the run's blocks (the first split's)."""
    cut = splits(recording, segment, blocks)
    chosen = cut[0] if cut else run_blocks(recording, segment, 1)
    spans = [(b.segment, b.start, b.end) for b in chosen]
    topics: dict[str, TopicRates] = {}
    for data in recording.topics:
        mine = data.part(data.segments == segment)
        if mine.count < 4:
            continue
        found = topic_rates(mine, spans, windows.get(data.name))
        if found is not None:
            topics[data.name] = found
    return RateSummary((recording.runs[segment].path,), topics)


def _needed(pairs: Sequence[Pair]) -> dict[str, tuple[set[str], bool]]:
    """Per topic: the fields the pairs read, and whether any is integrated."""
    out: dict[str, tuple[set[str], bool]] = {}
    for pair in pairs:
        for s in pair:
            fields, integrated = out.get(s.topic, (set(), False))
            fields.add(s.field)
            out[s.topic] = (fields, integrated or s.integrated)
    return out


def _only(data: TopicData, fields: set[str]) -> TopicData:
    rows = [i for i, f in enumerate(data.fields) if f in fields]
    return TopicData(
        data.name,
        data.msg_type,
        data.publishers,
        data.times,
        data.segments,
        tuple(data.fields[i] for i in rows),
        data.values[rows],
        data.stamps,
    )


def run_scales(
    recording: Recording, segment: int, pairs: Sequence[Pair], occurrences: int
) -> dict[Signal, tuple[float, float]]:
    """The floor and noise band of every signal of the pairs over a whole run."""
    topics = recording.topic_by_name()
    out: dict[Signal, tuple[float, float]] = {}
    for name, (fields, integrated) in _needed(pairs).items():
        if name in topics:
            part = _only(topics[name], fields).part(topics[name].segments == segment)
            found = topic_trends(part, occurrences, integrated)
            if found is not None:
                out.update(scales_of(found))
    return out


def block_trends(
    recording: Recording,
    block: Block,
    pairs: Sequence[Pair],
    occurrences: int,
    scales: dict[Signal, tuple[float, float]] | None = None,
) -> dict[str, TopicTrends]:
    """The trends of the pairs' signals on one block, from the block alone (its limits'
    floors and noise bands from ``scales``, the whole run's, where given)."""
    topics = recording.topic_by_name()
    out: dict[str, TopicTrends] = {}
    for name, (fields, integrated) in _needed(pairs).items():
        if name not in topics:
            continue
        part = block_topic(_only(topics[name], fields), block)
        found = topic_trends(part, occurrences, integrated, scales)
        if found is not None:
            out[name] = found
    return out


def headings(
    recording: Recording, block: Block, topics: frozenset[str] | None = None
) -> list[Heading]:
    """Every yaw signal of the recording (of ``topics``, where given) on one block."""
    out: list[Heading] = []
    for t in recording.topics:
        if "yaw" in t.fields and (topics is None or t.name in topics):
            part = block_topic(t, block)
            if part.count > 1:
                out.append((f"{t.name}.yaw", part.times, part.values[t.fields.index("yaw")]))
    return out


def summarize_relations(
    recording: Recording,
    segment: int,
    pairs: Sequence[Pair],
    blocks: int,
    occurrences: int,
    heading_topics: frozenset[str] | None = None,
    turning: Sequence[Pair] | None = None,
) -> RelationSummary:
    """One run's agreement of every pair on each block of each split, and, for the pairs
    of ``turning`` (all when None), per quadrant of the headings of ``heading_topics``
    (every yaw signal when None)."""
    judged_pairs = list(pairs if turning is None else turning)
    cut = splits(recording, segment, blocks) or (run_blocks(recording, segment, 1),)
    scales = run_scales(recording, segment, pairs, occurrences)
    per_split: list[tuple[BlockEvidence, ...]] = []
    quads: dict[Pair, Quadrants] = {}
    for k, chosen in enumerate(cut):
        found: list[BlockEvidence] = []
        for block in chosen:
            trends = block_trends(recording, block, pairs, occurrences, scales)
            judged = TrendSet(trends)
            evidence = judged.evidence(pairs)
            found.append({p: e for p, e in zip(pairs, evidence, strict=True) if e is not None})
            if k == 0:
                near = headings(recording, block, heading_topics)
                found_q = judged.quadrants(judged_pairs, near)
                for pair, q in zip(judged_pairs, found_q, strict=True):
                    if q is not None:
                        quads[pair] = quads[pair] + q if pair in quads else q
        per_split.append(tuple(found))
    return RelationSummary((recording.runs[segment].path,), tuple(per_split), quads)


def segments(recording: Recording) -> list[int]:
    """The runs of a recording that hold messages."""
    return [
        i
        for i in range(len(recording.runs))
        if any(np.any(t.segments == i) for t in recording.topics)
    ]
