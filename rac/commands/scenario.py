"""``racc scenario``: the dissertation's repair experiments (§10.1.1.1, §10.1.1.2).

``run`` computes a :class:`~rac.repair.ScenarioResult`, then prints it.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from typing import Any

from rac.board.client import parse_address
from rac.board.execute import parse_node_commands, suggested_commands
from rac.board.scenario import render as render_scenario
from rac.board.trip import device_shutdown_on_board
from rac.commands.common import add_command, count, json_text
from rac.commands.options import add_planner_options, add_scenario_options
from rac.commands.reports import EXIT_NO_PLAN, VALIDATED, plan_lines, validated_json
from rac.load.board import load_board_channels
from rac.load.theory import load_theory, robot_name
from rac.repair import PLANNER, SCENARIOS, Kind, NoRepairPlan, ScenarioResult
from rac.repair.scenario import run_scenario, state_json
from rac.repair.validate import validate_plan


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "scenario",
        "run a repair experiment: power-up or device-shutdown",
        "Break MODEL as a scenario says, derive what the observers would report, diagnose, "
        "plan the repair and print the diagnosis, the plan and the state after it. "
        "power-up (§10.1.1.1): every switchable device off, every node stopped. "
        "device-shutdown (§10.1.1.2): one device (--device, default the first switchable "
        "one) goes off while the rest runs.",
        "  racc scenario models/tedusar.ram power-up\n"
        "  racc scenario models/tedusar.ram device-shutdown --device hokuyo --json",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram, ram/1 .json or model.yaml file")
    parser.add_argument(
        "scenario", metavar="SCENARIO", choices=SCENARIOS, help=" or ".join(SCENARIOS)
    )
    parser.add_argument(
        "--device",
        metavar="D",
        help="device-shutdown: the switchable device that goes off (default: the first one "
        "declared)",
    )
    add_planner_options(parser, "print JSON (docs/spec.md#racc-scenario---json)")
    add_scenario_options(parser)  # --board --board-control --node-commands (issue 6)
    parser.set_defaults(run=run)


def compute(args: argparse.Namespace) -> ScenarioResult:
    theory = load_theory(args.model)
    result = run_scenario(
        theory, robot_name(theory, args.model), args.scenario, args.device, args.planner_timeout
    )
    repair = result.repair
    if args.validate and repair.plan:
        prepared = repair.prepared
        validate_plan(prepared.domain_text, prepared.problem_text, prepared.problem, repair.plan)
    return result


def report(result: ScenarioResult) -> str:
    scenario, repair = result.scenario, result.repair
    prepared = repair.prepared
    what = f" of {scenario.device}" if scenario.device else ""
    lines = [
        f"scenario {scenario.name}{what}: {len(prepared.observations)} observations, "
        f"{sum(not o.positive for o in prepared.observations)} of them negative",
        f"diagnosis: bad {{{', '.join(prepared.bad)}}}",
        f"plan ({count(len(repair.plan), 'step')}, {PLANNER}):",
        *plan_lines(repair.plan),
        "state after the plan:",
    ]
    state = state_json(prepared.problem.system, repair.final)
    width = max((len(c) for c in state), default=0)
    for comp, entry in state.items():
        if entry["kind"] == Kind.NODE.value:
            power = "running" if entry["running"] else "stopped"
        elif entry["kind"] == Kind.DEVICE.value:
            power = "on" if entry["on"] else "off"
        else:
            power = "-"
        health = "good" if entry["good"] else "bad"
        lines.append(f"  {comp:<{width}}  {entry['kind']:<8}  {power:<7}  {health}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    if args.device is not None and args.scenario != "device-shutdown":
        print("racc scenario: error: --device belongs to device-shutdown", file=sys.stderr)
        return 2  # a command line error, as argparse's
    if args.board:
        return run_board_scenario(args)
    try:
        result = compute(args)
    except NoRepairPlan as err:
        print(err.render(), file=sys.stderr)
        return EXIT_NO_PLAN
    if args.json:
        print(json_text(validated_json(result.to_json(), args, result.repair.plan), args))
    else:
        print(report(result))
        if args.validate and result.repair.plan:
            print(VALIDATED)
    return 0


def run_board_scenario(args: argparse.Namespace) -> int:
    """``racc scenario MODEL device-shutdown --board …``: end to end against the board."""
    if args.scenario != "device-shutdown":
        print(
            "racc scenario: error: --board runs the device-shutdown scenario only", file=sys.stderr
        )
        return 2  # a command line error, as argparse's
    load_board_channels(args.model)  # a model.yaml fails here, clearly
    theory = load_theory(args.model)
    templates = parse_node_commands(args.node_commands) if args.node_commands else None
    control = parse_address(args.board_control) if args.board_control else None
    try:
        result = asyncio.run(
            device_shutdown_on_board(
                theory,
                robot_name(theory, args.model),
                parse_address(args.board),
                device=args.device,
                control=control,
                node_commands=templates,
                suggest=suggested_commands(args.ros),
                planner_timeout_s=args.planner_timeout,
            )
        )
    except NoRepairPlan as err:
        print(err.render(), file=sys.stderr)
        return 3
    print(json_text(result.to_json(), args) if args.json else render_scenario(result))
    return 0
