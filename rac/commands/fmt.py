"""``racc fmt``: rewrite .ram files in canonical form (comments kept, idempotent)."""

from __future__ import annotations

import argparse
import difflib
import sys
from pathlib import Path
from typing import Any

from rac.commands.common import add_command
from rac.errors import Diagnostic, RacError
from rac.fmt import format_model
from rac.load.files import read_text
from rac.load.kinds import RAM_FILE, check_kind
from rac.load.output import write_file_atomically
from rac.parse import parse_ram


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "fmt",
        "format .ram files canonically",
        "Rewrite each FILE in canonical form. With --check or --diff, change nothing and "
        "exit 1 when a file is not formatted (for CI, as ruff format does); --diff also "
        "prints the change as a unified diff.",
        "  racc fmt models/tedusar.ram\n"
        "  racc fmt --check models/*.ram\n"
        "  racc fmt --diff robot.ram\n"
        "  racc fmt --check --diff models/*.ram",
    )
    parser.add_argument("files", metavar="FILE", nargs="+", help=".ram files")
    parser.add_argument(
        "--check", action="store_true", help="only report files that would change (exit 1)"
    )
    parser.add_argument(
        "--diff", action="store_true", help="print a unified diff, change nothing (exit 1)"
    )
    parser.set_defaults(run=run)


def _require_ram(names: list[str]) -> None:
    """RAC060 before anything is rewritten: the formatter reads and writes the .ram
    language, and a .json or model.yaml would otherwise be a syntax error at its first
    character (or, formatted, lose its own format)."""
    wrong = [n for n in names if n.endswith((".json", ".yaml", ".yml"))]
    found = [
        Diagnostic("RAC060", f"{n}: racc fmt formats .ram files only", hint=_hint(n)) for n in wrong
    ]
    for n in names:  # a directory, a recording: what it is, and what fmt takes
        if n not in wrong:
            try:
                check_kind(n, RAM_FILE, "RAC060")
            except RacError as err:
                found.extend(err.diagnostics)
    if found:
        raise RacError(found)


def _hint(name: str) -> str:
    """What to do instead, for the kind of file given: only a ram/1 .json becomes .ram."""
    if name.endswith(".json"):
        ram = name[: -len(".json")] + ".ram"
        return f"'racc export --ram {name} -o {ram}' writes a ram/1 model as .ram text"
    return (
        "a model.yaml (or other YAML) is written by racc compile and has no .ram form: "
        "format the .ram model it was compiled from"
    )


def run(args: argparse.Namespace) -> int:
    _require_ram(args.files)
    unformatted = 0
    for name in args.files:
        text = read_text(name)
        formatted = format_model(parse_ram(text, name))
        if formatted == text:
            continue
        unformatted += 1
        if args.check:
            print(f"would reformat {name}", file=sys.stderr)
        if args.diff:
            sys.stdout.writelines(
                difflib.unified_diff(
                    text.splitlines(keepends=True),
                    formatted.splitlines(keepends=True),
                    fromfile=name,
                    tofile=f"{name} (formatted)",
                )
            )
        if not (args.check or args.diff):
            write_file_atomically(Path(name), formatted)
            print(f"reformatted {name}", file=sys.stderr)
    if (args.check or args.diff) and unformatted:
        return 1
    return 0
