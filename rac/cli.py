"""The ``racc`` command line: one module per command under ``rac.commands``.

Exit codes for every command (contract §7): 0 done, 1 the input is wrong,
2 the command line is wrong, 3 no repair plan exists.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from rac import __version__
from rac.errors import RacError

EXIT_OK = 0
EXIT_INPUT = 1
EXIT_USAGE = 2
EXIT_NO_PLAN = 3

# Each module defines ``register(subparsers)``; its parser sets ``run``.
COMMANDS = (
    "compile",
    "check",
    "export",
    "fmt",
    "diagnose",
    "repair",
    "scenario",
    "simulate",
    "board",
    "board-sim",
    "learn",
    "synth",
    "observe",
    "engine",
    "repairer",
    "board-client",
    "record",
    "demo",
    "ros-package",
)

DESCRIPTION = """\
racc, the robot architecture compiler.

Describe a ROS robot in a .ram file; racc derives its diagnosis model
(Horn clauses), its observers, ROS launch files, a PDDL repair domain and a
diagram, and diagnoses and repairs faults with them."""

EPILOG = """\
examples:
  racc compile models/tedusar.ram -o build/tedusar
  racc check models/tedusar.ram
  racc COMMAND --help

exit codes: 0 done, 1 the input is wrong, 2 the command line is wrong, 3 no repair plan exists"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="racc",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"racc {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"rac.commands.{name.replace('-', '_')}")
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "run", None) is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        code: int = args.run(args)
    except RacError as err:
        print(err.render(), file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # The reader went away (`racc … | head`): not an error of ours.  Point stdout at
        # /dev/null so that the interpreter's final flush does not complain either.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    return code


if __name__ == "__main__":
    sys.exit(main())
