"""``racc export``: the model as ram/1 JSON (docs/spec.md) or as canonical .ram text."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, load_checked
from rac.fmt import format_model
from rac.interchange import dumps
from rac.load.output import write_file_atomically


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "export",
        "print a model as ram/1 JSON or as .ram text",
        "Validate MODEL and print it in the interchange format on standard output (or -o FILE).",
        "  racc export --json models/tedusar.ram > tedusar.json\n"
        "  racc export --ram tedusar.json -o tedusar.ram",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram file or a ram/1 .json")
    form = parser.add_mutually_exclusive_group(required=True)
    form.add_argument("--json", action="store_true", help="the ram/1 JSON interchange")
    form.add_argument("--ram", action="store_true", help="canonical .ram text")
    parser.add_argument("-o", "--output", metavar="FILE", help="write FILE instead of stdout")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    model = load_checked(args.model)
    text = dumps(model) if args.json else format_model(model)
    if args.output:
        write_file_atomically(Path(args.output), text)
        print(f"wrote {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
