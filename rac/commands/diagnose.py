"""``racc diagnose``: minimal conflicts and all minimal diagnoses of a set of observations."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from typing import Any

from rac.commands.common import add_command
from rac.diagnosis import DiagnosisResult, Literal, Theory, collect, diagnose, load_theory
from rac.diagnosis.theory import known_atoms, literal_at, parse_observations
from rac.loader import read_text


class _InOrder(argparse.Action):
    """Keep --obs and --obs-file in command-line order: later literals win (Algorithm 10)."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        sources = list(getattr(namespace, "sources", None) or [])
        sources.append((self.dest, values))
        namespace.sources = sources


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
    parser.set_defaults(sources=[])


def observations(args: argparse.Namespace, theory: Theory) -> tuple[Literal, ...]:
    """Θ from --obs and --obs-file in command-line order (docs/spec.md#observations)."""
    literals: list[Literal] = []
    known = known_atoms(theory)  # once: it is a pass over the whole model
    for kind, value in args.sources:
        if kind == "obs":
            literals.append(literal_at(value, theory, None, known))
        else:
            literals.extend(parse_observations(read_text(value), value, theory))
    return collect(literals)


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
        "--json", action="store_true", help="print JSON (docs/spec.md#racc-diagnose---json)"
    )
    parser.set_defaults(run=run)


def to_json(result: DiagnosisResult) -> dict[str, Any]:
    """Exactly the shape of docs/spec.md#racc-diagnose---json."""
    return {
        "consistent": result.consistent,
        "conflicts": [list(c) for c in result.conflicts],
        "diagnoses": [{"bad": list(d), "good": list(result.good(d))} for d in result.diagnoses],
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
    theory = load_theory(args.model)
    theta = observations(args, theory)
    result = diagnose(theory, theta, args.max_card)
    for note in notes(result, args.max_card):
        print(note, file=sys.stderr)
    if args.json:
        print(json.dumps(to_json(result)))
    else:
        print(table(result, len(theta)))
    return 0
