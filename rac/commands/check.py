"""``racc check``: validate a model without writing anything."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from rac.commands.common import add_command, count, load_and_compile
from rac.errors import RacError, Severity


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "check",
        "validate a model, write nothing",
        "Parse and validate each MODEL; print every error and warning with file, line and "
        "column, and a note (RAC104) naming each feedback loop of the data flow. Exits 1 when "
        "any model has an error.",
        "  racc check models/tedusar.ram\n  racc check models/*.ram\n  racc check -q robot.json",
    )
    parser.add_argument("models", metavar="MODEL", nargs="+", help="a .ram file or a ram/1 .json")
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="print only errors: no summary, no warnings"
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    failed = 0
    for path in args.models:
        try:
            _check(path, args.quiet)
        except RacError as err:
            if len(args.models) == 1:
                raise
            print(err.render(), file=sys.stderr)
            failed += 1
    return 1 if failed else 0


def _check(path: str, quiet: bool) -> None:
    compiled = load_and_compile(path, quiet=quiet)
    if quiet:
        return
    model = compiled.model
    notes = sum(d.severity is Severity.NOTE for d in compiled.warnings)
    print(
        f"{path}: ok ({count(len(model.nodes), 'node')}, "
        f"{count(len(model.hardware), 'hardware')}, {count(len(model.topics), 'topic')}, "
        f"{count(len(compiled.components), 'component')}, "
        f"{count(len(compiled.warnings) - notes, 'warning')}"
        + (f", {count(notes, 'feedback loop')})" if notes else ")")
    )
