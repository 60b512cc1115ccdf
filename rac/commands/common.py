"""Helpers the commands share: help formatting, model loading, atomic writes."""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import textwrap
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, NoReturn

from rac.errors import Diagnostic, RacError, did_you_mean

if TYPE_CHECKING:  # the compiler loads on first use: not every command compiles a model
    from rac.ir import Model
    from rac.pipeline import Compiled
    from rac.synth.truth import GroundTruth


_RUN = "\0"  # joins a run of values: no command-line argument can hold a NUL


_INVALID_CHOICE = re.compile(r"invalid choice: '?([^'(]*?)'? \(choose from (.*)\)$")


class SuggestingParser(argparse.ArgumentParser):
    """An argparse parser whose "invalid choice" error says which choice was meant (`racc
    compil`, `--mode crsh`), as racc's own errors do."""

    def error(self, message: str) -> NoReturn:
        found = _INVALID_CHOICE.search(message)
        if found is not None:
            choices = [c.strip().strip("'") for c in found.group(2).split(",")]
            close = did_you_mean(found.group(1), choices)
            if close:
                message = f"{message}; {close}"
        super().error(message)


class CommandParser(SuggestingParser):
    """A command's parser, linear in an option given thousands of times.

    argparse looks at every remaining option string at each option it meets, which is
    quadratic: ``--obs`` given 40,000 times took 40 s.  A run of consecutive uses of an
    option registered with :meth:`batch` reaches argparse as one use of a hidden option
    holding the run's values in order; its action must split them (:func:`run_values`).
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.batched: dict[str, str] = {}  # option -> the hidden option taking a run of it
        # ``NAME:=VALUE`` words after an option (``racc run DIR --ros 2 board:=H:P``) go to
        # this list attribute, which argparse's positional would not take a second time.
        self.assignments: str | None = None

    def batch(self, option: str, hidden: str) -> None:
        self.batched[option] = hidden

    def parse_known_args(  # type: ignore[override]
        self, args: Any = None, namespace: Any = None
    ) -> tuple[argparse.Namespace, list[str]]:
        if args is not None and self.batched:
            args = batched_runs(list(args), self.batched)
        parsed, extra = super().parse_known_args(args, namespace)
        if extra and self.assignments is not None:
            words = [w for w in extra if ":=" in w and not w.startswith("-")]
            setattr(parsed, self.assignments, [*getattr(parsed, self.assignments), *words])
            extra = [w for w in extra if w not in words]
        if extra:
            # Left to the top-level parser, the error would show `racc`'s usage, not the
            # command's: the user needs to see the options of the command they typed.
            self.error(f"unrecognized arguments: {' '.join(extra)}")
        return parsed, extra


def batched_runs(args: list[str], batched: Mapping[str, str]) -> list[str]:
    """``args`` with each run of two or more ``OPT VALUE`` (or ``OPT=VALUE``) of one batched
    option replaced by ``HIDDEN V1<NUL>V2…``; anything unusual is left to argparse as is."""
    out: list[str] = []
    i = 0
    while i < len(args):
        option, value, width = _batchable(args, i, batched)
        if option is None:
            if args[i] == "--":  # the rest is positional
                out.extend(args[i:])
                break
            out.append(args[i])
            i += 1
            continue
        values = [value]
        j = i + width
        while True:
            other, more, step = _batchable(args, j, batched)
            if other != option:
                break
            values.append(more)
            j += step
        if len(values) == 1:
            out.extend(args[i:j])
        else:
            out.extend((batched[option], _RUN.join(values)))
        i = j
    return out


def _batchable(args: list[str], i: int, batched: Mapping[str, str]) -> tuple[str | None, str, int]:
    """(option, value, how many arguments) when ``args[i]`` starts a batchable use."""
    if i >= len(args):
        return None, "", 0
    arg = args[i]
    if arg in batched and i + 1 < len(args):
        value, width = args[i + 1], 2
    elif "=" in arg and arg.split("=", 1)[0] in batched:
        arg, value = arg.split("=", 1)
        width = 1
    else:
        return None, "", 0
    if value.startswith("-") or _RUN in value:
        return None, "", 0  # argparse's own rules (and errors) for these
    return arg, value, width


def run_values(value: str) -> list[str]:
    """The values of a batched run (:class:`CommandParser`)."""
    return value.split(_RUN)


def add_command(
    sub: Any, name: str, summary: str, description: str, examples: str
) -> argparse.ArgumentParser:
    """A subcommand parser whose help ends with worked examples."""
    parser: argparse.ArgumentParser = sub.add_parser(
        name,
        help=summary,
        description=description,
        epilog="examples:\n" + examples,
        formatter_class=HelpFormatter,
    )
    return parser


class HelpFormatter(argparse.HelpFormatter):
    """Descriptions wrapped to the terminal, paragraph by paragraph; indented lines (the
    examples, lists) kept as written."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        out = []
        for paragraph in text.split("\n\n"):
            lines = paragraph.splitlines()
            if any(line[:1].isspace() for line in lines) or paragraph.startswith("examples:"):
                out.append("\n".join(indent + line for line in lines))
            else:
                out.append(
                    textwrap.fill(
                        " ".join(lines), width, initial_indent=indent, subsequent_indent=indent
                    )
                )
        return "\n\n".join(out)


def count(n: int, noun: str) -> str:
    """``1 node``, ``2 nodes``; ``hardware`` has no plural."""
    if n == 1 or noun in ("hardware", "Hz"):
        return f"{n} {noun}"
    return (
        f"{n} {noun[:-1]}ies" if noun.endswith("y") and noun[-2] not in "aeiou" else f"{n} {noun}s"
    )


def print_warnings(diagnostics: tuple[Diagnostic, ...], source: str | None) -> None:
    """The warnings, capped like errors (:meth:`RacError.render`)."""
    warnings = [d for d in diagnostics if not d.is_error]
    if warnings:
        print(RacError(warnings, source).render(), file=sys.stderr)


def checked_truth(
    truth: GroundTruth, models: Sequence[Model], *, quiet: bool, robot: bool = True
) -> None:
    """Stop (RAC086) when a culprit of the ground truth is in none of ``models``: every
    diagnosis would be scored wrong.  The RAC107 warning (another robot) unless ``quiet``."""
    from rac.synth.truth import check_truth

    found = check_truth(truth, models, robot)
    if any(d.is_error for d in found):
        raise RacError(found, truth.source)
    if found and not quiet:
        print_warnings(tuple(found), truth.source)


def load_and_compile(path: str, *, quiet: bool = False) -> Compiled:
    """Load a .ram/.json model, validate and derive; warnings go to stderr."""
    from rac.load.files import load_model
    from rac.pipeline import WARNINGS_LOCATED_UP_TO, compile_model, located

    model = load_model(path)
    compiled = compile_model(model)
    if not quiet and compiled.warnings:
        shown = located(model, compiled.warnings, up_to=WARNINGS_LOCATED_UP_TO)
        print_warnings(shown, model.source)
    return compiled


def load_checked(path: str) -> Model:
    return load_and_compile(path, quiet=True).model


def json_text(doc: Any, args: argparse.Namespace) -> str:
    """A command's ``--json`` output: one line, or indented with ``--pretty`` (the shapes are
    docs/spec.md's; whitespace is not part of them)."""
    return json.dumps(doc, indent=2 if getattr(args, "pretty", False) else None)


def add_ros_option(parser: argparse.ArgumentParser) -> None:
    """``--ros 1|2``: the transport of a live command (default: from the environment)."""
    parser.add_argument(
        "--ros",
        type=int,
        choices=(1, 2),
        help="ROS 1 (rospy) or ROS 2 (rclpy); default: ROS_VERSION, else ROS 2 when rclpy "
        "is importable and rospy is not, else ROS 1",
    )


def ros_version(args: argparse.Namespace) -> int:
    """The transport ``--ros`` names, or the one the environment has (see add_ros_option)."""
    import importlib.util

    chosen = getattr(args, "ros", None)
    if chosen in (1, 2):
        return int(chosen)
    env = os.environ.get("ROS_VERSION", "").strip()
    if env in ("1", "2"):
        return int(env)

    def importable(module: str) -> bool:
        try:
            return importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            return False

    return 2 if importable("rclpy") and not importable("rospy") else 1
