"""``racc diagnose``: minimal conflicts and all minimal diagnoses of a set of observations."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from rac.commands.common import CommandParser, add_command, json_text, run_values
from rac.diagnosis import DiagnosisResult, Literal, Theory, collect, compile_theory, load_theory
from rac.diagnosis.result import diagnose_ids
from rac.diagnosis.theory import known_lookup, literal_at, parse_observations, plain_lines
from rac.loader import read_text
from rac.perf import paused_gc


class _InOrder(argparse.Action):
    """Keep --obs and --obs-file in command-line order: later literals win (Algorithm 10).

    Appends in place (O(1)): copying the list at each use, as argparse's ``append`` does,
    is quadratic in the number of uses.  A batched run (``--obs-run``, see
    :class:`~rac.commands.common.CommandParser`) adds each of its literals.
    """

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        sources = getattr(namespace, "sources", None)
        if sources is None:  # a fresh list per parse, never the shared default
            sources = namespace.sources = []
        if self.dest == "obs_run":
            sources.extend(("obs", value) for value in run_values(values))
        else:
            sources.append((self.dest, values))


def card(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError("must be 0 or more")
    return value


def add_observation_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--obs",
        metavar="LIT",
        action=_InOrder,
        help="an observed literal: 'ok(pose)', 'not ok(pose)', 'not_ok(pose)' (repeatable)",
    )
    parser.add_argument(
        "--obs-file",
        metavar="F",
        action=_InOrder,
        help="a file with one literal per line, '#' comments (repeatable)",
    )
    if isinstance(parser, CommandParser):
        parser.add_argument("--obs-run", action=_InOrder, help=argparse.SUPPRESS)
        parser.batch("--obs", "--obs-run")
    parser.set_defaults(sources=None)


def observations(args: argparse.Namespace, theory: Theory) -> tuple[Literal, ...]:
    """Θ from --obs and --obs-file in command-line order (docs/spec.md#observations)."""
    literals: list[Literal] = []
    known = known_lookup(theory)  # once: a look-up in the theory's clause index
    for kind, value in args.sources or ():
        if kind == "obs":
            literals.append(literal_at(value, theory, None, known))
        else:
            literals.extend(parse_observations(read_text(value), value, theory, known))
    return collect(literals)


def observed_ids(args: argparse.Namespace, theory: Theory) -> list[int]:
    """:func:`observations` as atom numbers of the theory's index, for :func:`diagnose_ids`.

    A file of plain literal lines (what generators write) is read in one pass straight to
    atom numbers; anything else goes through the literal parser, with its diagnostics.
    """
    index = compile_theory(theory)
    known = index.known
    observed: list[int] = []
    for kind, value in args.sources or ():
        if kind == "obs":
            observed.append(index.literal_atom(literal_at(value, theory, None, known)))
            continue
        text = read_text(value)
        lines = plain_lines(text)
        fast = index.plain_ids(lines) if lines is not None else None
        if fast is None:
            fast = index.observed_ids(parse_observations(text, value, theory, known))
        observed.extend(fast)
    return index.collect_ids(observed)


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
    parser.add_argument(
        "--max-card",
        metavar="K",
        type=card,
        default=None,
        help="search diagnoses of at most K faulty components (default: no bound)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print JSON: consistent, conflicts, and the bad components of each diagnosis "
        "(docs/spec.md#racc-diagnose---json)",
    )
    add_with_good_option(parser)
    parser.set_defaults(run=run)


def add_with_good_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--with-good",
        action="store_true",
        help="with --json, also list each diagnosis's good components (all the others)",
    )


def to_json(result: DiagnosisResult, with_good: bool = False) -> dict[str, Any]:
    """``{"consistent", "conflicts", "diagnoses": [{"bad": [...]}]}``; each diagnosis also has
    ``"good"`` (every other component, sorted) with ``with_good``.  Without it the output
    stays small: a large robot has thousands of good components per diagnosis."""
    diagnoses: list[dict[str, Any]] = []
    for d in result.diagnoses:
        entry: dict[str, Any] = {"bad": list(d)}
        if with_good:
            entry["good"] = list(result.good(d))
        diagnoses.append(entry)
    return {
        "consistent": result.consistent,
        "conflicts": [list(c) for c in result.conflicts],
        "diagnoses": diagnoses,
    }


def notes(result: DiagnosisResult, max_card: int | None) -> list[str]:
    lines = []
    if result.bounded:
        lines.append(
            f"note: the search was bounded at {max_card} faulty component(s); "
            "larger diagnoses were not explored, so the lists may be incomplete"
        )
    if not result.consistent and not result.diagnoses and not result.bounded:
        lines.append(
            "note: the observations contradict the model whatever the components do; "
            "no diagnosis exists (check the observations)"
        )
    return lines


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


def require_json_for_good(args: argparse.Namespace, command: str) -> None:
    """``--with-good`` shapes the JSON only: alone it would be silently ignored."""
    if args.with_good and not args.json:
        print(
            f"racc {command}: error: --with-good goes with --json "
            "(the table lists each diagnosis's bad components only)",
            file=sys.stderr,
        )
        raise SystemExit(2)


def _diagnose(args: argparse.Namespace) -> int:
    require_json_for_good(args, "diagnose")
    theory = load_theory(args.model)
    theta = observed_ids(args, theory)
    result = diagnose_ids(theory, theta, args.max_card)
    for note in notes(result, args.max_card):
        print(note, file=sys.stderr)
    if args.json:
        print(json_text(to_json(result, args.with_good), args))
    else:
        print(table(result, len(theta)))
    return 0
