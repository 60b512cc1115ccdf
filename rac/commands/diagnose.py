"""``racc diagnose``: minimal conflicts and all minimal diagnoses of a set of observations."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from rac.commands.common import add_command, json_text
from rac.commands.options import (
    add_max_card_option,
    add_observation_options,
    add_with_good_option,
    require_json_for_good,
)
from rac.commands.reports import diagnosis_json, diagnosis_notes
from rac.diagnosis import DiagnosisResult
from rac.diagnosis.result import diagnose_ids
from rac.load.observations import read_observed_ids
from rac.load.theory import load_theory
from rac.perf import paused_gc


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "diagnose",
        "compute the minimal diagnoses of a set of observations",
        "Check the observations against the model (clauses ∪ Θ ∪ {NAB(c)}); when they "
        "contradict it, print the minimal conflict sets and all minimal diagnoses "
        "(Reiter's hitting sets). MODEL is a .ram, a ram/1 .json or a model-server model.yaml.",
        "  racc diagnose models/tedusar.ram --obs 'on(jaguar)' --obs 'running(jaguar_node)' "
        "--obs 'not ok(pose)'\n"
        "  racc diagnose build/tedusar/model.yaml --obs-file observations.txt --json\n"
        "  racc diagnose robot.ram --obs 'not ok(pose)' --json --with-good\n"
        "  racc diagnose robot.ram --obs-file obs.txt --max-card 2",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram, a ram/1 .json or a model.yaml")
    add_observation_options(parser)
    add_max_card_option(parser)
    parser.add_argument(
        "--json",
        action="store_true",
        help="print JSON: consistent, conflicts, and the bad components of each diagnosis "
        "(docs/spec.md#racc-diagnose---json)",
    )
    add_with_good_option(parser)
    parser.set_defaults(run=run)


def _braces(names: Sequence[str]) -> str:
    return "{" + ", ".join(names) + "}"


def table(result: DiagnosisResult, observed: int) -> str:
    lines = [
        f"observations: {observed}, components: {len(result.components)}",
        "consistent: yes, no fault detected"
        if result.consistent
        else "consistent: no, fault detected",
    ]
    if not result.consistent:
        lines.append(f"minimal conflicts ({len(result.conflicts)}):")
        lines.extend(f"  {_braces(c)}" for c in result.conflicts)
    lines.append(f"minimal diagnoses ({len(result.diagnoses)}):")
    width = max([len("bad"), *(len(", ".join(d)) for d in result.diagnoses)])
    lines.append(f"  {'#':>3}  {'bad':<{width}}  good")
    for number, bad in enumerate(result.diagnoses, start=1):
        good = result.good(bad)
        shown = ", ".join(bad) or "-"
        lines.append(f"  {number:>3}  {shown:<{width}}  {len(good)} others")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    # One pause of the cyclic GC over the whole command, not one per step: each step's pause
    # ends in a collection of everything it allocated (the whole theory, on a large model),
    # while nothing the command builds is cyclic garbage (see rac.perf).
    with paused_gc():
        return _diagnose(args)


def _diagnose(args: argparse.Namespace) -> int:
    require_json_for_good(args, "diagnose")
    theory = load_theory(args.model)
    theta = read_observed_ids(args.sources, theory)
    result = diagnose_ids(theory, theta, args.max_card)
    for note in diagnosis_notes(result, args.max_card):
        print(note, file=sys.stderr)
    if args.json:
        print(json_text(diagnosis_json(result, args.with_good), args))
    else:
        print(table(result, len(theta)))
    return 0
