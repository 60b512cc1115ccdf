"""Which candidate relations are kept (Algorithms 16 and 17, judged as docs/learning.md says).

The candidates (:mod:`rac.learn.candidates`) are judged on the recordings' summaries
(:mod:`rac.learn.summary`): the learning rule and held-out validation on two splits
(:mod:`rac.learn.holdout`), Holm's correction in two families (the graph and semantic
candidates among themselves; the unexplained ones against every candidate tried), the
heading invariance, and at most ``per_edge`` relations per graph edge (one relation per
node input and output is enough to isolate the node; more would repeat its evidence).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from rac.ir import Node, Related
from rac.learn.candidates import (
    GRAPH,
    Candidate,
    TopicInfo,
    candidate_fields,
    candidates,
    copies,
)
from rac.learn.correlate import pooled
from rac.learn.holdout import HeldOut, heading_dependence, held_out, passes_fit, with_holm
from rac.learn.options import LearnOptions
from rac.learn.recording import Recording
from rac.learn.relations import Judged, LearnedRelation, group_relations
from rac.learn.structure import varying_fields
from rac.learn.summary import (
    Mapper,
    Pair,
    RelationSummary,
    merge_relations,
    segments,
    serial,
    summarize_relations,
)


@dataclass(frozen=True, slots=True)
class Relations:
    """What relation learning gives: the declarations, the relations behind them, every
    judged candidate (for the report), comments on the rejected ones, and how many kept
    relations the second split would have changed."""

    related: tuple[Related, ...]
    kept: tuple[LearnedRelation, ...]
    judged: tuple[Judged, ...]
    rejected: tuple[str, ...]
    unstable: int


def topic_infos(recording: Recording, declared: set[str]) -> list[TopicInfo]:
    return [
        TopicInfo(t.name, t.msg_type, candidate_fields(varying_fields(t)))
        for t in recording.topics
        if t.name in declared
    ]


def judge(
    found: Sequence[Candidate], summary: RelationSummary, options: LearnOptions
) -> list[Judged]:
    """Every candidate's verdict (see the module)."""
    pairs: list[Pair] = [(c.a, c.b) for c in found]
    n_splits = len(summary.splits)
    if not options.blocks:
        out = []
        for c, pair in zip(found, pairs, strict=True):
            parts = [e for e in summary.evidence(0, pair) if e is not None]
            why = (
                ""
                if passes_fit(parts, options.q, options.min_lift)
                else (f"its ratio is not above Q {options.q:g} by the lift over chance")
            )
            out.append(Judged(c, pooled(parts), (), len(found), why))
        return out
    tiers = [c.reading.tier for c in found]
    families = {1: sum(1 for t in tiers if t == 1), 2: len(found)}
    per_split: list[list[HeldOut]] = []
    for k in range(n_splits):
        raw = [held_out(summary.evidence(k, pair), options.q, options.min_lift) for pair in pairs]
        corrected: list[HeldOut | None] = [None] * len(found)
        for tier, family in families.items():
            chosen = [i for i, t in enumerate(tiers) if t == tier]
            for i, v in zip(
                chosen,
                with_holm([raw[i] for i in chosen], family, options.significance),
                strict=True,
            ):
                corrected[i] = v
        per_split.append([v for v in corrected if v is not None])
    out = []
    for i, c in enumerate(found):
        verdicts = tuple(s[i] for s in per_split)
        whole = pooled([e for e in summary.evidence(0, pairs[i]) if e is not None])
        why = verdicts[0].why_not
        if not why and len(verdicts) > 1 and not verdicts[1].kept:
            why = (
                f"unstable: it holds when the recording is cut one way and not another "
                f"({verdicts[1].why_not})"
            )
        if not why:
            why = heading_dependence(summary.quadrants.get(pairs[i]), options.min_lift)
        out.append(Judged(c, whole, verdicts, families[tiers[i]], why))
    return out


def _per_edge(judged: list[Judged], limit: int) -> list[Judged]:
    """At most ``limit`` kept graph relations per edge, the strongest (lowest p)."""
    if limit <= 0:
        return judged
    best: dict[tuple[str, str, str], list[int]] = {}
    for i, j in enumerate(judged):
        edge = j.candidate.reading.edge
        if j.kept and j.candidate.reading.kind == GRAPH and edge is not None:
            best.setdefault(edge, []).append(i)
    out = list(judged)
    for edge, members in best.items():
        ranked = sorted(members, key=lambda i: (_p(judged[i]), -judged[i].whole.ratio))
        for i in ranked[limit:]:
            why = (
                f"the edge {edge[0]}: {edge[1]} → {edge[2]} has a stronger relation already "
                f"(at most {limit} per edge: --per-edge)"
            )
            out[i] = replace(judged[i], why_not=why)
    return out


def _p(j: Judged) -> float:
    return j.verdicts[0].pooled.p if j.verdicts else -j.whole.z


def learn_relations(
    recording: Recording,
    options: LearnOptions,
    declared: set[str],
    declarable: set[str],
    steady: set[str],
    nodes: Sequence[Node],
    notes: list[str],
    undeclared: list[str],
    mapper: Mapper = serial,
) -> Relations:
    """Relations between the declared topics, as ``relate`` declarations where both topics
    have a publisher."""
    infos = topic_infos(recording, declared)
    if sum(len(t.fields) for t in infos) < 2:
        notes.append(
            "no two varying numeric signals are left to relate, so no relations are learned "
            "(are the topics' fields constant, or excluded by the base model's field lists?)"
        )
        return Relations((), (), (), (), 0)
    found = candidates(infos, nodes, steady, options.blind)
    meaningful = sum(1 for c in found if c.reading.tier == 1)
    if found and not meaningful:
        notes.append(
            f"neither the graph nor the message types give a candidate relation: {len(found)} "
            "pairs searched blind, every relation kept is marked unexplained (give --graph or "
            "--base for the data flow)"
        )
    if not found:
        return Relations((), (), (), (), 0)
    pairs: list[Pair] = [(c.a, c.b) for c in found]
    # The headings of the measurements: a relayed copy of a heading has its quadrants.
    derived = copies(nodes, {t.name: t.msg_type for t in infos})
    heading_topics = frozenset(t.name for t in infos if "yaw" in t.fields) - derived
    # A field against its own relayed copy cannot depend on the heading: only the other
    # pairs are split by heading quadrant.
    turning = [(c.a, c.b) for c in found if c.a.field != c.b.field or c.reading.kind != GRAPH]

    def one(segment: int) -> object:
        return summarize_relations(
            recording,
            segment,
            pairs,
            options.blocks,
            options.occurrences,
            heading_topics,
            turning,
        )

    summaries = [s for s in mapper(one, segments(recording)) if isinstance(s, RelationSummary)]
    summary = merge_relations(summaries)
    if options.blocks and all(len(split) < 2 for split in summary.splits):
        notes.append(
            "the recording is too short to cut into blocks: relations are judged on the whole "
            "of it, not held out"
        )
    judged = _per_edge(judge(found, summary, options), options.per_edge)
    unstable = sum(
        1 for j in judged if len(j.verdicts) > 1 and j.verdicts[0].kept != j.verdicts[1].kept
    )
    kept = [j for j in judged if j.kept]
    rejected = [
        f"not kept: {j.text} ({j.whole.ratio:.2f}, {j.candidate.reading.kind}): {j.why_not}"
        for j in judged
        if not j.kept and math.isfinite(j.whole.ratio) and _passed_fit(j, options)
    ]
    if rejected:
        notes.append(
            f"{len(rejected)} candidate relations that pass Q did not hold (held out, "
            "significance, stability, heading or one per edge), not kept: the end of the "
            "model says why"
        )
    if unstable:
        notes.append(
            f"{unstable} candidate relations held under one split of the recording and not "
            "under the other: not kept (unstable)"
        )
    related: list[Related] = []
    learned: list[LearnedRelation] = []
    for rel in group_relations(kept):
        if not {rel.a[0], rel.b[0]} <= declarable:
            undeclared.append(
                f"{rel.declaration()}: {rel.evidence()} (a topic has no known publisher)"
            )
            continue
        related.append(Related(*rel.sides(), comments=rel.comments()))
        learned.append(rel)
    return Relations(tuple(related), tuple(learned), tuple(judged), tuple(rejected), unstable)


def _passed_fit(j: Judged, options: LearnOptions) -> bool:
    w = j.whole
    return w.checks > 0 and w.ratio > options.q and w.ratio >= w.chance + options.min_lift
