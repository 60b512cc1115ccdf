"""``racc place``: the cheapest added observers that make every detectable fault isolable."""

from __future__ import annotations

import argparse
import difflib
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from rac.analysis.place import DEFAULT_COSTS, Candidate, Placement, place
from rac.commands.common import add_command, json_text, print_warnings
from rac.diagnosis.modes import MODES
from rac.errors import Diagnostic, Severity, did_you_mean
from rac.fmt import format_model
from rac.load.costs import load_costs
from rac.load.files import load_model
from rac.load.output import check_output_file, write_file_atomically
from rac.load.theory import load_theory


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "place",
        "propose the cheapest observers that make the faults isolable",
        "Analyse MODEL in one fault mode (output by default), then choose additional "
        "observers (a GObs per topic without a rate, a PObs per node, a DObs per driven device, "
        "and the rates, limits, relations and intervals of a learned model) so that every "
        "detectable fault is detected and told apart, at the least cost: an integer covering "
        "and separating program whose LP relaxation clarabel solves, rounded and improved "
        "greedily.  Prints the LP lower bound, the cost and the scores before and after on "
        "stderr, and the .ram patch (a unified diff of the canonical text, one comment per "
        "observer naming the ambiguity it resolves) on stdout or into -o FILE.  Values racc "
        "cannot know (the rate of a new GObs, a new limit) are placeholders, marked so.",
        "  racc place models/tedusar.ram\n"
        "  racc place models/pioneer.ram --budget 2 -o pioneer.patch\n"
        "  racc place robot.ram --candidates learned.ram --costs costs.yaml --mode crash",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram or a ram/1 .json")
    parser.add_argument(
        "--mode",
        choices=MODES,
        default="output",
        help="the fault mode to make isolable (default: output)",
    )
    parser.add_argument(
        "--budget",
        metavar="N",
        type=_budget,
        help="spend at most N cost units, 1 per observer unless --costs says otherwise (default: "
        "no budget)",
    )
    parser.add_argument(
        "--candidates",
        metavar="LEARNED",
        help="a learned .ram (racc learn): its rates, limits and relations become candidates "
        "(default: placeholder values)",
    )
    parser.add_argument(
        "--costs",
        metavar="COSTS",
        help="YAML map from an observer kind (GObs: 1), a candidate ('GObs /map': 5) or what it "
        "watches (/map: 5) to its cost (default: 1 each)",
    )
    parser.add_argument(
        "-o", "--output", metavar="FILE", help="write the .ram patch to FILE (default: stdout)"
    )
    parser.add_argument("--json", action="store_true", help="print the placement as JSON")
    parser.set_defaults(run=run)


def _budget(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"the budget must be ≥ 0, not {text}")
    return value


def patch_text(path: str, placement: Placement) -> str:
    model = load_model(path)
    before = format_model(model)
    after = format_model(placement.patched)
    name = Path(path).name
    return "".join(
        difflib.unified_diff(
            before.splitlines(keepends=True),
            after.splitlines(keepends=True),
            fromfile=f"a/{name}",
            tofile=f"b/{name}",
        )
    )


def summary(p: Placement) -> str:
    b, a = p.before, p.after
    lines = [
        f"mode {p.mode}: {len(p.candidates)} candidate observers, {len(p.requirements)} "
        f"requirements",
        f"chosen ({len(p.chosen)}, cost {p.cost:g}): "
        + (", ".join(p.candidates[j].name for j in p.chosen) or "none"),
    ]
    if p.budget is None:
        ratio = p.cost / p.lp_bound if p.lp_bound > 1e-9 else 1.0
        lines.append(f"LP lower bound {p.lp_bound:.3f}; cost / bound = {ratio:.3f}")
    else:
        lines.append(
            f"budget {p.budget:g}: at most {p.lp_bound:.2f} requirements by the LP bound, "
            f"{sum(1 for r in p.requirements if set(p.chosen) & set(r.options))} met"
        )
    lines.append(
        f"before: detectable {b.detectable}/{len(b.faults)}, isolable {b.isolable}/{len(b.faults)}"
        f"; after: detectable {a.detectable}/{len(a.faults)}, isolable {a.isolable}/{len(a.faults)}"
    )
    unmeasured = [
        p.candidates[j].key
        for j in p.chosen
        if p.candidates[j].kind == "GObs" and not p.candidates[j].learned
    ]
    if unmeasured:
        lines.append(
            f"rates to measure (racc record, racc learn): {', '.join(unmeasured)}; the patch "
            "writes none, 'after' counts them as periodic"
        )
    for r in p.unresolvable:
        lines.append(f"no candidate observer {r.describe()}")
    return "\n".join(lines)


def unused_costs(
    path: str, costs: Mapping[str, float], candidates: Sequence[Candidate]
) -> tuple[Diagnostic, ...]:
    """RAC181 for each key of the costs file that prices no candidate: a misspelt name
    (``GObs /mapp``) would otherwise leave its observer at the default cost, silently."""
    known = set(DEFAULT_COSTS) | {c.key for c in candidates}
    known |= {f"{c.kind} {c.key}" for c in candidates}
    found = []
    for key in costs:
        if key in known:
            continue
        message = f"{path}: '{key}' prices no candidate observer of this model and mode"
        hint = did_you_mean(key, known) or (
            "keys are an observer kind (GObs), a candidate (/map, 'node cpu') or both "
            "('GObs /map'); the candidates are in racc place --json"
        )
        found.append(Diagnostic("RAC181", message, severity=Severity.WARNING, hint=hint))
    return tuple(found)


def run(args: argparse.Namespace) -> int:
    check_output_file(args.output)
    theory = load_theory(args.model)
    learned = load_model(args.candidates) if args.candidates else None
    costs = load_costs(args.costs) if args.costs else None
    placement = place(theory, args.mode, args.budget, learned, costs)
    if costs and not args.quiet:
        print_warnings(unused_costs(args.costs, costs, placement.candidates), None)
    text = patch_text(args.model, placement)
    if args.json:
        doc = {
            "mode": placement.mode,
            "lp_bound": round(placement.lp_bound, 6),
            "cost": placement.cost,
            "chosen": [
                {
                    "kind": placement.candidates[j].kind,
                    "watches": placement.candidates[j].key,
                    "resolves": [r.describe() for r in placement.resolves(j)],
                }
                for j in placement.chosen
            ],
            "unresolvable": [r.describe() for r in placement.unresolvable],
            "before": {
                "detectable": placement.before.detectable,
                "isolable": placement.before.isolable,
            },
            "after": {
                "detectable": placement.after.detectable,
                "isolable": placement.after.isolable,
            },
            "faults": len(placement.after.faults),
            "patch": text,
        }
        print(json_text(doc, args))
        return 0
    print(summary(placement), file=sys.stderr)
    if args.output:
        write_file_atomically(Path(args.output), text)
    else:
        print(text, end="")
    return 0
