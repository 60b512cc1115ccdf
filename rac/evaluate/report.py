"""The evaluation as text, Markdown or JSON: Tables 10.1, 10.2, §10.2.3 and the comparison."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from rac.evaluate import stats
from rac.evaluate.evaluation import Evaluation, ModelResult

OBSERVER_COLUMNS = (
    ("BiQObs", "BiQObs"),
    ("GObs", "GObs"),
    ("NObs", "NObs"),
    ("PObs_cpu", "PObs cpu"),
    ("PObs_mem", "PObs mem"),
    ("DObs", "DObs"),
    ("HObs", "HObs"),
    ("IObs", "IObs"),
)
ALWAYS_SHOWN = frozenset({"BiQObs", "GObs", "NObs", "PObs_cpu", "PObs_mem"})
ALPHA = stats.ALPHA


def _cell(value: object) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.3f}"
    return str(value)


def table(headers: Sequence[str], rows: Sequence[Sequence[object]], markdown: bool) -> str:
    cells = [[_cell(c) for c in row] for row in rows]
    if markdown:
        out = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
        out += ["| " + " | ".join(r) + " |" for r in cells]
        return "\n".join(out)
    widths = [max(len(h), *(len(r[i]) for r in cells)) for i, h in enumerate(headers)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True)).rstrip()]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in cells]
    return "\n".join(lines)


def _observer_table(ev: Evaluation, markdown: bool) -> str:
    shown = [
        (key, title)
        for key, title in OBSERVER_COLUMNS
        if key in ALWAYS_SHOWN or any(m.observers.get(key) for m in ev.results)
    ]
    headers = ["model", "Q", "alpha", *(t for _, t in shown), "total"]
    rows = [
        [
            m.candidate.label,
            m.candidate.q,
            m.candidate.alpha,
            *(m.observers.get(k, 0) for k, _ in shown),
            sum(m.observers.values()),
        ]
        for m in ev.results
    ]
    return table(headers, rows, markdown)


def _outcome_table(ev: Evaluation, markdown: bool) -> str:
    kinds = ev.kinds
    # "ideal": what a perfect model scores (every injected fault CR, no FN or FP); the
    # dissertation's "target" column, renamed since a fault's target is its topic or node.
    headers = ["", "fault", "ideal", *(m.candidate.label for m in ev.results)]
    rows: list[list[object]] = []
    for what in ("CR", "FN", "FP"):
        for kind in kinds:
            if what != "FP" and kind == "none":
                continue
            ideal = (
                sum(1 for r in ev.runs for f in r.faults if f.kind == kind) if what == "CR" else 0
            )
            rows.append([what, kind, ideal, *(m.count(what, kind) for m in ev.results)])
        total = [r for r in rows if r[0] == what]
        rows.append(
            [
                what,
                "sum",
                sum(int(str(r[2])) for r in total),
                *(sum(m.count(what, k) for k in kinds) for m in ev.results),
            ]
        )
    return table(headers, rows, markdown)


def _mean(values: Sequence[float]) -> float | None:
    return sum(values) / len(values) if values else None


def _honest_table(ev: Evaluation, markdown: bool) -> str:
    """Per model: faults detected, isolated, the mean latency, and false episodes (their
    number and time per hour of healthy recording)."""
    faults = sum(len(r.faults) for r in ev.runs)
    headers = [
        "model",
        f"detected (of {faults})",
        "isolated",
        "mean latency (s)",
        "false episodes",
        "per hour",
        "false s per hour",
        "healthy s",
    ]
    rows: list[list[object]] = []
    for m in ev.results:
        rows.append(
            [
                m.candidate.label,
                sum(m.vector),
                sum(o.isolated for _, o in m.outcomes),
                _mean(m.latencies()),
                len(m.false_positives),
                m.false_per_hour,
                m.false_time_per_hour,
                round(m.healthy_s, 1),
            ]
        )
    return table(headers, rows, markdown)


def _vector_table(ev: Evaluation, markdown: bool) -> str:
    n = len(ev.results[0].vector) if ev.results else 0
    headers = ["model", *(str(i) for i in range(1, n + 1)), "mu", "sigma"]
    rows: list[list[object]] = []
    for m in ev.results:
        if not m.vector:
            rows.append([m.candidate.label, None, None])
            continue
        summary = stats.summarize(m.vector)
        mu, sigma = summary.mean, summary.sd
        rows.append([m.candidate.label, *m.vector, mu, sigma])
    return table(headers, rows, markdown)


def ranked(ev: Evaluation) -> tuple[ModelResult, ModelResult] | None:
    """The best and the worst model: most faults reported, then fewest false positives;
    ties go to the earlier model.  None with fewer than two models, or when all scored
    alike."""
    if len(ev.results) < 2:
        return None

    def key(m: ModelResult) -> tuple[int, int]:
        return (sum(m.vector), -len(m.false_positives))

    best, worst = max(ev.results, key=key), min(ev.results, key=key)
    return None if key(best) == key(worst) else (best, worst)


def comparison(ev: Evaluation) -> dict[str, Any] | None:
    pair = ranked(ev)
    if pair is None or not pair[0].vector:
        return None
    best, worst = pair
    low, high = stats.summarize(worst.vector), stats.summarize(best.vector)
    thesis = stats.z_test_dissertation(low, high, ALPHA)
    corrected = stats.z_test(low, high, ALPHA)
    exact = stats.mcnemar(worst.vector, best.vector, ALPHA)
    return {
        "best": best.candidate.label,
        "worst": worst.candidate.label,
        "z_thesis": {"z": thesis.statistic, "p": thesis.p, "significant": thesis.significant},
        "z_corrected": {
            "z": corrected.statistic,
            "p": corrected.p,
            "significant": corrected.significant,
        },
        "mcnemar": {
            "best_only": exact.c,
            "worst_only": exact.b,
            "p": exact.p,
            "significant": exact.significant,
        },
    }


def _comparison_text(ev: Evaluation) -> list[str]:
    c = comparison(ev)
    if c is None:
        if len(ev.results) >= 2 and any(r.faults for r in ev.runs):
            return ["every model reported the same number of faults with as many false "
                    "positives: nothing to compare"]  # fmt: skip
        return ["(the comparison needs at least two models and one fault)"]

    def verdict(entry: dict[str, Any]) -> str:
        return "significant" if entry["significant"] else "not significant"

    zt, zc, mc = c["z_thesis"], c["z_corrected"], c["mcnemar"]
    return [
        f"best {c['best']}, worst {c['worst']} (alpha = {ALPHA}):",
        f"- z-test as the dissertation computes it (sigma/n): z = {zt['z']:.3f}, "
        f"p = {zt['p']:.4f}, {verdict(zt)}",
        f"- z-test corrected (sigma^2/n): z = {zc['z']:.3f}, p = {zc['p']:.4f}, {verdict(zc)}",
        f"- McNemar's exact test: {mc['best_only']} faults only {c['best']} reported, "
        f"{mc['worst_only']} only {c['worst']}; p = {mc['p']:.4f}, {verdict(mc)}",
    ]


def render(ev: Evaluation, markdown: bool) -> str:
    head = "### " if markdown else ""
    faults = sum(len(r.faults) for r in ev.runs)
    parts = [
        f"{head}Observers per model (Table 10.1)",
        _observer_table(ev, markdown),
        "",
        f"{head}Faults reported (Table 10.2): {_count(faults, 'fault')} in "
        f"{_count(len(ev.runs), 'run')}, "
        f"grace {ev.grace:g} s",
        _outcome_table(ev, markdown),
        "",
        f"{head}Detection, isolation, latency and false episodes",
        _honest_table(ev, markdown),
        "",
        f"{head}Per fault, 1 = correctly reported (§10.2.3)",
        _vector_table(ev, markdown),
        "",
        f"{head}Best against worst",
        *_comparison_text(ev),
    ]
    fps = [(m, run, fp) for m in ev.results for run, fp in m.false_positives]
    if fps:
        parts += ["", f"{head}False positives"]
        for m, run, fp in fps:
            names = " | ".join("[" + ", ".join(d) + "]" for d in fp.episode.diagnoses)
            bullet = "- " if markdown else "  "
            parts.append(f"{bullet}{m.candidate.label} {run} at {fp.episode.start:.1f} s: {names}")
    return "\n".join(parts) + "\n"


def to_json(ev: Evaluation, pretty: bool = False) -> str:
    doc = {
        "grace_s": ev.grace,
        "runs": [
            {
                "path": r.path,
                "faults": [
                    {
                        "kind": f.kind,
                        "target": f.target,
                        "start": f.start,
                        "end": f.end,
                        "culprits": list(f.culprits),
                    }
                    for f in r.faults
                ],
            }
            for r in ev.runs
        ],
        "models": [_model_json(m, ev) for m in ev.results],
        "comparison": comparison(ev),
    }
    return json.dumps(doc, indent=2 if pretty else None) + "\n"


def _model_json(m: ModelResult, ev: Evaluation) -> dict[str, Any]:
    summary = stats.summarize(m.vector) if m.vector else None
    mu = summary.mean if summary else None
    sigma = summary.sd if summary else None
    return {
        "label": m.candidate.label,
        "source": m.candidate.source,
        "q": m.candidate.q,
        "alpha": m.candidate.alpha,
        "observers": dict(sorted(m.observers.items())),
        "counts": {
            what: {k: m.count(what, k) for k in ev.kinds if not (what != "FP" and k == "none")}
            for what in ("CR", "FN", "FP")
        },
        "outcomes": [
            {
                "run": run,
                "kind": o.fault.kind,
                "target": o.fault.target,
                "reported": o.reported,
                "first": o.first,
                "detected": o.reported,
                "latency_s": o.latency,
                "isolated": o.isolated,
                "candidates": o.candidates,
            }
            for run, o in m.outcomes
        ],
        "healthy_s": m.healthy_s,
        "false_episodes_per_hour": m.false_per_hour,
        "false_s_per_hour": m.false_time_per_hour,
        "false_positives": [
            {
                "run": run,
                "kind": fp.kind,
                "start": fp.episode.start,
                "end": fp.episode.end,
                "diagnoses": [list(d) for d in fp.episode.diagnoses],
            }
            for run, fp in m.false_positives
        ],
        "mu": mu,
        "sigma": sigma,
    }


def _count(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"
