"""``racc repair``: diagnose the observations, choose what to repair, plan with Fast Downward.

``run`` computes a :class:`~rac.repair.RepairResult`, then prints it; a command
that executes the plan can reuse ``compute``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rac.commands.board import add_execute_options, execute_repair
from rac.commands.common import add_command, json_text, write_file_atomically
from rac.commands.diagnose import add_observation_options, card, notes, observations
from rac.diagnosis import diagnose, load_theory
from rac.repair import (
    DEFAULT_TIMEOUT_S,
    PLANNER,
    STRATEGIES,
    NoRepairPlan,
    Prepared,
    RepairResult,
    Step,
    prepare,
    robot_name,
    solve,
)
from rac.repair.validate import validate_plan

EXIT_NO_PLAN = 3
MAX_TIMEOUT_S = 1e6  # eleven days


def seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError("must be more than 0")
    if not value <= MAX_TIMEOUT_S:  # inf, or beyond what the OS timers take
        raise argparse.ArgumentTypeError(f"must be at most {MAX_TIMEOUT_S:g} seconds")
    return value


def add_planner_options(
    parser: argparse.ArgumentParser, json_help: str = "print JSON (docs/spec.md#racc-repair---json)"
) -> None:
    parser.add_argument(
        "--planner-timeout",
        metavar="S",
        type=seconds,
        default=DEFAULT_TIMEOUT_S,
        help="give the planner at most S seconds (default: %(default)g)",
    )
    parser.add_argument(
        "--validate",
        action="store_true",
        help="check the plan with unified-planning's plan validator (optional extra)",
    )
    parser.add_argument("--json", action="store_true", help=json_help)


VALIDATED = "plan validated by unified-planning's plan validator"


def validated_json(doc: dict[str, Any], args: argparse.Namespace, plan: tuple[Step, ...]) -> Any:
    """``validated``: true when --validate checked a plan (an invalid one is an error)."""
    if args.validate:
        doc["validated"] = bool(plan)
    return doc


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "repair",
        "plan the repair of a diagnosed fault",
        "Diagnose the observations against MODEL (.ram, ram/1 .json or model.yaml), choose the "
        "components to repair, and plan their repair with Fast Downward in the PDDL repair "
        "domain: a bad node is restarted, a bad switchable device power-cycled, and a driver "
        "restarted after its device. Prints the plan as numbered steps. Exit code 3 when no "
        "plan exists (non-switchable hardware diagnosed faulty, an unsolvable problem, a "
        "missing or failing planner, a time-out).",
        "  racc repair models/tedusar.ram --obs 'on(jaguar)' --obs 'running(jaguar_node)' "
        "--obs 'not ok(pose)'\n"
        "  racc repair build/tedusar/model.yaml --obs-file obs.txt --json --validate\n"
        "  racc repair models/tedusar.ram --obs 'not running(hector_mapping)' "
        "--strategy first --problem-out problem.pddl",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram, ram/1 .json or model.yaml file")
    add_observation_options(parser)
    parser.add_argument(
        "--strategy",
        choices=STRATEGIES,
        default="minimal",
        help="minimal: repair every component of the minimum-cardinality diagnoses in one "
        "plan (default); first: repair the first diagnosis only, as the dissertation does",
    )
    parser.add_argument(
        "--max-card",
        metavar="K",
        type=card,
        default=None,
        help="search diagnoses of at most K faulty components (default: no bound)",
    )
    parser.add_argument(
        "--problem-out", metavar="F", help="also write the PDDL repair problem to file F"
    )
    add_planner_options(parser)
    add_execute_options(parser)  # --execute --board --node-commands (issue 6, rac/board)
    parser.set_defaults(run=run)


def step_text(step: Step) -> str:
    return f"{step[0]}({', '.join(step[1:])})"


def plan_lines(plan: tuple[Step, ...]) -> list[str]:
    return [f"{i}. {step_text(step)}" for i, step in enumerate(plan, 1)]


def compute(args: argparse.Namespace) -> RepairResult:
    """Diagnose, choose, plan (and validate): the result the command prints."""
    theory = load_theory(args.model)
    theta = observations(args, theory)
    diagnosis = diagnose(theory, theta, args.max_card)
    for note in notes(diagnosis, args.max_card):
        print(note, file=sys.stderr)
    robot = robot_name(theory, args.model)
    prepared = prepare(theory, theta, robot, args.strategy, diagnosis=diagnosis)
    if args.problem_out:
        write_file_atomically(Path(args.problem_out), prepared.problem_text)
    result = solve(prepared, args.planner_timeout)
    if args.validate and result.plan:
        validate_plan(prepared.domain_text, prepared.problem_text, prepared.problem, result.plan)
    return result


def report(result: RepairResult) -> str:
    prepared = result.prepared
    if not prepared.bad:
        return "no repair needed: the observations are consistent with every component working"
    count = len(prepared.diagnosis.diagnoses)
    how = f"{prepared.strategy} strategy, {count} minimal diagnos{'is' if count == 1 else 'es'}"
    lines = [
        f"diagnosis: bad {{{', '.join(prepared.bad)}}} ({how})",
        f"plan ({len(result.plan)} step{'' if len(result.plan) == 1 else 's'}, {PLANNER}):",
        *plan_lines(result.plan),
    ]
    lines.extend(_why_several(prepared))
    skipped = _skipped_diagnoses(prepared)
    if skipped:
        lines.append(
            "note: also possible, but no action can repair it: "
            + "; ".join(f"{{{', '.join(d)}}}" for d in skipped)
            + " (check that hardware by hand if the fault persists)"
        )
    return "\n".join(lines)


def _why_several(prepared: Prepared) -> list[str]:
    """The minimal strategy repairs several candidates at once: say why, and what helps."""
    if prepared.strategy != "minimal" or not prepared.diagnosis.diagnoses:
        return []
    fewest = min(len(d) for d in prepared.diagnosis.diagnoses)
    chosen = set(prepared.bad)
    candidates = [d for d in prepared.diagnosis.diagnoses if len(d) == fewest and set(d) <= chosen]
    if len(candidates) < 2:
        return []
    shown = " or ".join(f"{{{', '.join(d)}}}" for d in candidates)
    return [
        f"note: the observations cannot yet tell {shown} apart, so the plan repairs all of "
        "them; add observers that separate them ('racc place MODEL' proposes some)"
    ]


def _skipped_diagnoses(prepared: Prepared) -> list[tuple[str, ...]]:
    """Minimum-cardinality diagnoses the minimal strategy left out as unrepairable."""
    if prepared.strategy != "minimal" or not prepared.diagnosis.diagnoses:
        return []
    fewest = min(len(d) for d in prepared.diagnosis.diagnoses)
    chosen = set(prepared.bad)
    return [d for d in prepared.diagnosis.diagnoses if len(d) == fewest and not set(d) <= chosen]


def run(args: argparse.Namespace) -> int:
    try:
        result = compute(args)
    except NoRepairPlan as err:
        print(err.render(), file=sys.stderr)
        return EXIT_NO_PLAN
    if args.json:
        print(json_text(validated_json(result.to_json(), args, result.plan), args))
    else:
        print(report(result))
        if args.validate and result.plan:
            print(VALIDATED)
    if args.execute:
        return execute_repair(args, result.plan)
    return 0
