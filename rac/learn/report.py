"""The ``--report`` JSON of ``racc learn`` and the observer counts of Table 10.1."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from rac.ir import Model
from rac.learn.holdout import HeldOut
from rac.learn.relations import Judged

if TYPE_CHECKING:
    from rac.learn.learner import LearnResult


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


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _verdict(v: HeldOut) -> dict[str, Any]:
    p = v.pooled
    return {
        "blocks": v.blocks,
        "folds_selecting": v.folds,
        "ratio": p.ratio,
        "chance": p.chance,
        "checks": p.checks,
        "effective_checks": p.effective,
        "z": p.z,
        "p": p.p,
        "holm_threshold": _finite(v.threshold),
        "lowest_block_lift": _finite(v.lowest),
        "kept": v.kept,
        "why_not": v.why_not or None,
    }


def _candidate(j: Judged, declared: dict[frozenset[str], str]) -> dict[str, Any]:
    c = j.candidate
    w = j.whole
    return {
        "a": c.a.text,
        "b": c.b.text,
        "reading": c.reading.kind,
        "meaning": c.reading.text,
        "edge": list(c.reading.edge) if c.reading.edge is not None else None,
        "evidence": {
            "ratio": w.ratio,
            "chance": w.chance,
            "checks": w.checks,
            "effective_checks": w.effective,
            "z": w.z,
            "p": w.p,
            "family": j.family,
        },
        "held_out": [_verdict(v) for v in j.verdicts],
        "kept": j.kept,
        "why_not": j.why_not or None,
        "declared": declared.get(frozenset((c.a.text, c.b.text))),
    }


def report(result: LearnResult) -> dict[str, Any]:
    """The ``--report`` JSON: parameters, counts per observer kind (Table 10.1), evidence."""
    o = result.options
    regular = {t.name.value: t for t in result.model.topics if t.regular}
    in_model = {
        frozenset((r.a.text, r.b.text)): f"relate {r.a.text} ~ {r.b.text}"
        for r in result.model.related
    }
    declared: dict[frozenset[str], str] = {}
    for rel in result.relations:
        a, b = rel.sides()
        line = in_model.get(frozenset((a.text, b.text)))
        if line is None:
            continue
        for v in rel.variants:
            declared[frozenset((v.candidate.a.text, v.candidate.b.text))] = line
    return {
        "format": "racc-learn-report/1",
        "robot": result.model.name.value,
        "parameters": {
            "alpha": o.alpha,
            "Q": o.q,
            "occurrences": o.occurrences,
            "min_lift": o.min_lift,
            "sigmas": o.sigmas,
            "blocks": o.blocks,
            "significance": o.significance,
            "blind": o.blind,
            "per_edge": o.per_edge,
            "exclude": list(o.exclude),
        },
        "observers": observer_counts(result.model),
        "topics": [
            {
                "topic": s.topic,
                "intervals": s.samples,
                "mean_interval_s": s.mean,
                "stddev_s": s.stddev,
                "ratio": _finite(s.ratio),
                "regular": s.topic in regular,
                "rate_hz": regular[s.topic].rate_hz if s.topic in regular else None,
                "tolerance_hz": regular[s.topic].rate_tolerance_hz if s.topic in regular else None,
                "median_interval_s": _finite(s.median),
                "gaps": s.gaps,
                "gap_s": s.gap_s,
                "clock": "header stamps" if s.stamped else "receive times",
            }
            for s in result.rates
        ],
        "related": [
            {
                "a": f"{r.a[0]}.{r.a[1]}",
                "b": f"{r.b[0]}.{r.b[1]}",
                "integrated_only": r.integrated,
                "declared": in_model.get(frozenset((r.sides()[0].text, r.sides()[1].text))),
                "reading": r.reading.kind,
                "meaning": r.reading.text,
                "variants": [
                    {
                        "a": v.candidate.a.text,
                        "b": v.candidate.b.text,
                        "ratio": v.whole.ratio,
                        "matches": round(v.whole.ratio * v.whole.checks),
                        "checks": v.whole.checks,
                        "chance": v.whole.chance,
                        "effective_checks": v.whole.effective,
                    }
                    for v in r.variants
                ],
                "held_out": [_verdict(v) for v in r.best.verdicts],
            }
            for r in result.relations
        ],
        "candidates": [
            _candidate(j, declared)
            for j in result.judged
            if j.candidate.reading.tier == 1 or j.kept or _passes(j, o.q, o.min_lift)
        ],
        "stability": {"splits": 2 if o.blocks else 1, "changed": result.unstable},
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


def _passes(j: Judged, q: float, min_lift: float) -> bool:
    w = j.whole
    return w.checks > 0 and w.ratio > q and w.ratio >= w.chance + min_lift
