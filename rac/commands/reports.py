"""Text and JSON more than one command prints (diagnoses, repair plans)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rac.diagnosis import DiagnosisResult, Theory
    from rac.pipeline import Compiled
    from rac.repair import Step
    from rac.replay.timeline import Timeline
    from rac.targets.coverage import Health

# racc compile marks them on architecture.dot up to this many nodes: the analysis took 0.3 s
# of CPU at 100 nodes and 3 s at 300 (bench/compile.py's generator), which would have
# multiplied a 300-node compile's time by four.  Above it the caption says "not analysed".
COMPILE_ANALYSIS_UP_TO_NODES = 100


def diagnosis_json(result: DiagnosisResult, with_good: bool = False) -> dict[str, Any]:
    """``{"consistent", "conflicts", "diagnoses": [{"bad": [...]}]}``; each diagnosis also has
    ``"good"`` (every other component, sorted) with ``with_good``.  Without it the output
    stays small: a large robot has thousands of good components per diagnosis."""
    diagnoses: list[dict[str, Any]] = []
    for d in result.diagnoses:
        entry: dict[str, Any] = {"bad": list(d)}
        if with_good:
            entry["good"] = list(result.good(d))
        diagnoses.append(entry)
    return {
        "consistent": result.consistent,
        "conflicts": [list(c) for c in result.conflicts],
        "diagnoses": diagnoses,
    }


def diagnosis_notes(result: DiagnosisResult, max_card: int | None) -> list[str]:
    lines = []
    if result.bounded:
        lines.append(
            f"note: the search was bounded at {max_card} faulty component(s); "
            "larger diagnoses were not explored, so the lists may be incomplete"
        )
    if not result.consistent and not result.diagnoses and not result.bounded:
        lines.append(
            "note: the observations contradict the model whatever the components do; "
            "no diagnosis exists (check the observations)"
        )
    return lines


EXIT_NO_PLAN = 3
VALIDATED = "plan validated by unified-planning's plan validator"


def validated_json(doc: dict[str, Any], args: argparse.Namespace, plan: tuple[Step, ...]) -> Any:
    """``validated``: true when --validate checked a plan (an invalid one is an error)."""
    if args.validate:
        doc["validated"] = bool(plan)
    return doc


def step_text(step: Step) -> str:
    return f"{step[0]}({', '.join(step[1:])})"


def plan_lines(plan: tuple[Step, ...]) -> list[str]:
    return [f"{i}. {step_text(step)}" for i, step in enumerate(plan, 1)]


# -- diagrams of a diagnosis (racc diagram, racc replay --diagram-at) -------------------------


def diagnosis_title(diagnoses: Sequence[Sequence[str]], consistent: bool, what: str) -> str:
    if consistent:
        return f"{what}: consistent, no fault"
    if not diagnoses:
        return f"{what}: no diagnosis explains them"
    shown = " | ".join("{" + ", ".join(d) + "}" for d in diagnoses[:4])
    more = f" (+{len(diagnoses) - 4} more)" if len(diagnoses) > 4 else ""
    return f"{what}: minimal diagnoses {shown}{more}"


def replay_health(timeline: Timeline, at: float) -> Health:
    """What a replay had observed and diagnosed at ``at`` seconds."""
    # On first use, as in the rest of this module: racc diagnose imports it and needs none.
    from rac.logic import NEG_PREFIX, parse_atom
    from rac.replay.timeline import DiagnosisRecord, ObservationRecord
    from rac.targets.coverage import Health

    diagnoses: tuple[tuple[str, ...], ...] = ()
    held: dict[Any, bool] = {}
    for record in timeline.records:
        if record.t > at:
            break
        if isinstance(record, DiagnosisRecord):
            diagnoses = record.diagnoses
        elif isinstance(record, ObservationRecord):
            positive = not record.literal.startswith(NEG_PREFIX)
            held[parse_atom(record.literal.removeprefix(NEG_PREFIX))] = positive
    bad = sum(1 for v in held.values() if not v)
    what = f"replay at {at:g} s, {len(held)} observations, {bad} bad"
    title = diagnosis_title(diagnoses, not diagnoses, what)
    return Health(title, diagnoses, tuple(held.items()))


def draw_health(compiled: Compiled, at: float, timeline: Timeline, output: str) -> None:
    """``racc replay --diagram-at``: the architecture as the replay saw it ``at`` seconds in."""
    from rac.load.drawing import check_suffix, write_diagram
    from rac.targets.dot import View, emit_diagram

    view = View(health=replay_health(timeline, at))
    write_diagram(
        output, emit_diagram(compiled.model, compiled.observers, view), check_suffix(output)
    )


def compile_undetected(
    compiled: Compiled, quiet: bool
) -> tuple[tuple[str, tuple[str, ...]], ...] | None:
    """What ``racc compile`` marks on architecture.dot: the faults no observer detects, up to
    COMPILE_ANALYSIS_UP_TO_NODES nodes."""
    if len(compiled.model.nodes) > COMPILE_ANALYSIS_UP_TO_NODES:
        return None
    # on first use: every command imports this module, and rac.diagnosis is not light
    from rac.diagnosis.theory import theory_of

    return undetected_faults(theory_of(compiled), quiet)


def undetected_faults(theory: Theory, quiet: bool) -> tuple[tuple[str, tuple[str, ...]], ...]:
    from rac.analysis.analyze import undetected
    from rac.diagnosis.modes import MODES

    if not quiet and sys.stderr.isatty():
        print("analysing which faults the observers detect…", end="\r", file=sys.stderr)
    found = undetected(theory, MODES)
    if not quiet and sys.stderr.isatty():
        print(" " * 50, end="\r", file=sys.stderr)
    return tuple(sorted(found.items()))
