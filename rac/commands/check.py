"""``racc check``: validate a model without writing anything."""

from __future__ import annotations

import argparse
from typing import Any

from rac.commands.common import add_command, load_and_compile
from rac.errors import Severity


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "check",
        "validate a model, write nothing",
        "Parse and validate MODEL; print every error and warning with file, line and column, "
        "and a note (RAC104) naming each feedback loop of the data flow.",
        "  racc check models/tedusar.ram\n  racc check robot.json",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram file or a ram/1 .json")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    compiled = load_and_compile(args.model)
    model = compiled.model
    notes = sum(d.severity is Severity.NOTE for d in compiled.warnings)
    print(
        f"{args.model}: ok ({len(model.nodes)} nodes, {len(model.hardware)} hardware, "
        f"{len(model.topics)} topics, {len(compiled.components)} components, "
        f"{len(compiled.warnings) - notes} warnings"
        + (f", {notes} feedback loop{'s' if notes > 1 else ''})" if notes else ")")
    )
    return 0
