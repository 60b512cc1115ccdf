"""``racc repair``: diagnose the observations, choose what to repair, plan with Fast Downward.

``run`` computes a :class:`~rac.repair.RepairResult`, then prints it; a command
that executes the plan can reuse ``compute``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rac.board.channels import ChannelMap
from rac.board.client import parse_address
from rac.board.execute import (
    HARDWARE_ACTIONS,
    parse_node_commands,
    reports_json,
    run_plan,
    suggested_commands,
)
from rac.commands.common import add_command, count, json_text
from rac.commands.options import (
    add_execute_options,
    add_max_card_option,
    add_observation_options,
    add_planner_options,
)
from rac.commands.reports import (
    EXIT_NO_PLAN,
    VALIDATED,
    diagnosis_notes,
    plan_lines,
    validated_json,
)
from rac.diagnosis import diagnose
from rac.errors import Diagnostic, RacError
from rac.load.board import load_board_channels
from rac.load.observations import read_observations
from rac.load.output import write_file_atomically
from rac.load.theory import load_theory, robot_name
from rac.repair import (
    PLANNER,
    STRATEGIES,
    NoRepairPlan,
    Prepared,
    RepairResult,
    prepare,
    solve,
)
from rac.repair.validate import validate_plan


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
    add_max_card_option(parser)
    parser.add_argument(
        "--problem-out", metavar="F", help="also write the PDDL repair problem to file F"
    )
    add_planner_options(parser)
    add_execute_options(parser)  # --execute --board --node-commands (issue 6, rac/board)
    parser.set_defaults(run=run)


def compute(args: argparse.Namespace) -> RepairResult:
    """Diagnose, choose, plan (and validate): the result the command prints."""
    theory = load_theory(args.model)
    theta = read_observations(args.sources, theory)
    diagnosis = diagnose(theory, theta, args.max_card)
    for note in diagnosis_notes(diagnosis, args.max_card):
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


# -- `racc repair --execute` (issue 6, item 4): the plan carried out through rac.board ------


def execute_repair(args: argparse.Namespace, plan: Sequence[Sequence[str]]) -> int:
    """Execute a repair plan after ``racc repair`` printed it; RacError (exit 1) on failure."""
    steps = [(step[0], step[1]) for step in plan]
    hardware = any(action in HARDWARE_ACTIONS for action, _ in steps)
    if hardware and not args.board:
        raise RacError(
            [Diagnostic("RAC090", "--execute needs --board HOST:PORT for power_up/shutdown steps")]
        )
    channels = load_board_channels(args.model) if hardware else ChannelMap()
    templates = parse_node_commands(args.node_commands) if args.node_commands else None
    address = parse_address(args.board) if args.board else None
    reports = run_plan(
        steps, channels, address, node_commands=templates, suggest=suggested_commands(args.ros)
    )
    if args.json:
        print(json_text(reports_json(reports), args))
    else:
        done = sum(r.executed for r in reports)
        print(f"executed {done} of {count(len(reports), 'step')}:")
        for i, r in enumerate(reports, 1):
            print(f"{i}. {r}" if r.executed else f"{i}. not run: {r}")
    return 0
