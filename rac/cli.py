"""The ``racc`` command line: one module per command under ``rac.commands``.

Exit codes for every command (docs/spec.md#exit-codes): 0 done, 1 the input is wrong,
2 the command line is wrong, 3 no repair plan exists, 70 an internal error (a bug in racc).
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import importlib
import io
import os
import sys
from collections.abc import Sequence

from rac import __version__
from rac.commands.common import CommandParser, SuggestingParser
from rac.errors import RacError

EXIT_OK = 0
EXIT_INPUT = 1
EXIT_USAGE = 2
EXIT_NO_PLAN = 3
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports a Ctrl-C
EXIT_INTERNAL = 70  # EX_SOFTWARE of sysexits.h: a bug in racc, never a verdict on the input

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
    "replay",
    "evaluate",
    "analyze",
    "diagram",
    "place",
    "import-model",  # `racc import`: `import` cannot name a module
    "observe",
    "engine",
    "repairer",
    "board-client",
    "record",
    "demo",
    "run",
    "watch",
    "confirm",
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

exit codes: 0 done, 1 the input is wrong, 2 the command line is wrong, 3 no repair plan exists,
  70 internal error (a bug in racc: please report it; --debug or RACC_DEBUG=1 shows the
  traceback)"""


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or of ``only`` (a command's imports are its own cost)."""
    parser = SuggestingParser(
        prog="racc",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"racc {__version__}")
    parser.add_argument(
        "--debug",
        action="store_true",
        help="on an internal error, print the Python traceback (also: RACC_DEBUG=1)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=CommandParser)
    for name in COMMANDS if only is None else (only,):
        module = importlib.import_module(f"rac.commands.{name.replace('-', '_')}")
        module.register(sub)
    for command in sub.choices.values():
        _add_quiet(command)
        _add_pretty(command)
    return parser


def _command_of(argv: Sequence[str]) -> str | None:
    """The command named on the command line, when it is one of :data:`COMMANDS`."""
    for arg in argv:
        if not arg.startswith("-"):
            return arg if arg in COMMANDS else None
    return None


def _add_pretty(command: argparse.ArgumentParser) -> None:
    """``--pretty`` beside every ``--json`` that prints a report: ``--json`` is one line,
    ``--json --pretty`` indented (``racc export --json`` writes the ram/1 file format)."""
    if command.prog.endswith(" export"):
        return
    for action in command._actions:
        if isinstance(action, argparse._SubParsersAction):  # racc board status --json
            for child in action.choices.values():
                _add_pretty(child)
    options = {o for action in command._actions for o in action.option_strings}
    if "--json" in options and "--pretty" not in options:
        command.add_argument(
            "--pretty",
            action="store_true",
            help="with --json: indent the JSON (default: one line)",
        )


def _add_quiet(command: argparse.ArgumentParser) -> None:
    """``-q`` on every command: those without their own meaning for it keep stderr quiet."""
    if any("-q" in action.option_strings for action in command._actions):
        return
    command.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="print no warnings or progress on standard error (errors still)",
    )
    command.set_defaults(quiet_stderr=True)


def main(argv: Sequence[str] | None = None) -> int:
    try:
        return _main(argv)
    finally:
        # The command is done and the process is about to end: the collector's last pass at
        # exit would walk every object still held (a 10,000-node model's theory and index:
        # about 0.1 s of a 0.7 s `racc diagnose`), only to find nothing to collect.
        # Objects alive now are left to reference counting; later garbage is collected as usual.
        gc.freeze()


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser(_command_of(sys.argv[1:] if argv is None else argv))
    args = parser.parse_args(argv)
    if getattr(args, "run", None) is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        if getattr(args, "quiet_stderr", False) and args.quiet:
            with contextlib.redirect_stderr(io.StringIO()):
                code: int = args.run(args)
        else:
            code = args.run(args)
    except RacError as err:
        print(err.render(), file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader went away (`racc … | head`): not an error of ours.  Point stdout at
        # /dev/null so that the interpreter's final flush does not complain either.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as err:
        return internal_error(err, debug=args.debug or _env_debug())
    return code


def _env_debug() -> bool:
    return os.environ.get("RACC_DEBUG", "").strip() not in ("", "0")


def internal_error(err: BaseException, *, debug: bool) -> int:
    """Report a bug in racc: one short line (the traceback with --debug), exit 70."""
    summary = str(err).splitlines()[0] if str(err) else ""
    summary = summary if len(summary) <= 200 else summary[:200] + "…"
    print(f"racc: internal error (please report): {type(err).__name__}: {summary}", file=sys.stderr)
    if debug:
        import traceback

        traceback.print_exception(err, file=sys.stderr)
    else:
        print("racc: run again with --debug (or RACC_DEBUG=1) for the traceback", file=sys.stderr)
    return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
