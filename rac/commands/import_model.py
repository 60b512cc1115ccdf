"""``racc import tug``: a tug_diagnosis configuration as a .ram model."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, count, print_warnings
from rac.commands.options import rate_hz
from rac.errors import Diagnostic, RacError
from rac.fmt import format_model
from rac.load.output import check_output_file, write_file_atomically
from rac.load.tug import load_tug
from rac.pipeline import compile_model
from rac.tug import DEFAULT_RATE_HZ


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "import",
        "read another system's configuration as a .ram model",
        "FORMAT tug: a tug_diagnosis configuration (the dissertation's successor system): its "
        "'nodes' (name, pub_topic, sub_topic) become nodes whose every output depends on all "
        "of their inputs, as tug_diagnosis models them, and its 'observations' become "
        "observers where the language has them (hz: a topic rate; activated: the node "
        "observer every node has).  Everything else (timeout, timestamp, resources without "
        "values, timing, velocity, scores, unknown keys) is reported on stderr as a note "
        "(RAC106) naming what it would need, and listed in the model's header comments.  The "
        "model is validated before it is written; its feedback loops are named (RAC104).",
        "  racc import tug config_paul.yaml -o paul.ram\n"
        "  racc import tug config.yaml -o robot.ram --name knapp --default-rate 20",
    )
    parser.add_argument("format", choices=("tug",), help="the configuration's format")
    parser.add_argument("config", metavar="CONFIG", help="the configuration YAML")
    parser.add_argument("-o", "--output", metavar="FILE", required=True, help="the .ram to write")
    parser.add_argument("--name", help="the robot's name (default: the file's stem)")
    parser.add_argument(
        "--default-rate",
        metavar="HZ",
        type=rate_hz,
        default=DEFAULT_RATE_HZ,
        help=f"the rate written for hz-observed topics (default {DEFAULT_RATE_HZ:g})",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    name = args.name or Path(args.config).stem
    check_output_file(args.output)
    imported = load_tug(args.config, name, args.default_rate)
    model = imported.model
    # The model's names carry their spans in the configuration: an error of the model is
    # shown at the configuration's line, and the generated text is never dumped.
    try:
        compiled = compile_model(model)
    except RacError as err:
        raise RacError(err.diagnostics, imported.source) from None
    print_warnings(imported.diagnostics(), imported.source)
    print_warnings(compiled.warnings, imported.source)
    text = format_model(model)
    body = text.split("\n", len(model.comments))
    corrected = [f"{_where(d)}{d.message}" for d in imported.warnings]
    notes = "".join(f"# import: {n}\n" for n in [*corrected, *imported.notes])
    out = "\n".join(body[: len(model.comments)]) + "\n" + notes + body[-1]
    write_file_atomically(Path(args.output), out)
    print(
        f"{args.output}: {count(len(model.nodes), 'node')}, "
        f"{count(len(model.topics), 'topic')}, {count(len(compiled.components), 'component')}, "
        f"{count(len(imported.notes), 'note')}",
        file=sys.stderr,
    )
    return 0


def _where(d: Diagnostic) -> str:
    return f"line {d.span.line}: " if d.span is not None else ""
