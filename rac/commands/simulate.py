"""``racc simulate``: inject faults, predict the observations, check the diagnosis finds them."""

from __future__ import annotations

import argparse
from typing import Any

from rac.commands.common import add_command, json_text
from rac.commands.options import add_max_card_option, add_with_good_option, require_json_for_good
from rac.commands.reports import diagnosis_json
from rac.diagnosis import Simulation, all_single_faults, ambiguity_groups, simulate
from rac.diagnosis.modes import MODES
from rac.load.theory import load_theory


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "simulate",
        "inject faults and check that the model detects and isolates them",
        "Predict what the observers would report with the given components faulty (an "
        "observable atom holds iff the clauses derive it with those components abnormal and "
        "all others normal, else its negation is observed), diagnose those observations and "
        "report whether the fault was detected and whether the injected set is a diagnosis. "
        "--all-single-faults does this for every component and names the ambiguity groups "
        "(components the model cannot tell apart).  --mode says how the components fail: "
        "crash (the default: the component stops, everything it reports and publishes goes "
        "bad), output (a node runs but its outputs are wrong) or silent-hardware (a device is "
        "dead while the board still shows it powered).",
        "  racc simulate models/tedusar.ram --fault jaguar\n"
        "  racc simulate models/pioneer.ram --all-single-faults --mode output\n"
        "  racc simulate models/tedusar.ram --fault imu_node --fault hokuyo --json\n"
        "  racc simulate models/tedusar.ram --all-single-faults",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram, a ram/1 .json or a model.yaml")
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument(
        "--fault", metavar="C", action="append", help="a faulty component (repeatable)"
    )
    what.add_argument(
        "--all-single-faults", action="store_true", help="inject each component's fault in turn"
    )
    add_max_card_option(parser)
    parser.add_argument(
        "--mode",
        choices=MODES,
        default="crash",
        help="how the injected components fail (default: crash)",
    )
    parser.add_argument(
        "--json", action="store_true", help="print JSON (docs/spec.md#racc-simulate---json)"
    )
    add_with_good_option(parser)
    parser.set_defaults(run=run)


def _yes(flag: bool) -> str:
    return "yes" if flag else "no"


def single_report(sim: Simulation) -> str:
    lines = [f"injected: {', '.join(sim.faults) or '(none)'} (mode: {sim.mode})"]
    changed = [str(o) for o in sim.observations if not o.positive]
    lines.append(f"predicted negative observations ({len(changed)}): {', '.join(changed) or '-'}")
    lines.append(f"detected: {_yes(sim.detected)}")
    lines.append(f"minimal diagnoses ({len(sim.result.diagnoses)}):")
    lines.extend(f"  {{{', '.join(d)}}}" for d in sim.result.diagnoses)
    lines.append(f"injected set among them: {_yes(sim.found)}; isolated: {_yes(sim.isolated)}")
    if sim.result.bounded:
        lines.append("note: the search was bounded by --max-card; the list may be incomplete")
    return "\n".join(lines)


def single_json(sim: Simulation, with_good: bool = False) -> dict[str, Any]:
    return {
        "faults": list(sim.faults),
        "mode": sim.mode,
        "observations": [str(o) for o in sim.observations],
        "detected": sim.detected,
        **diagnosis_json(sim.result, with_good),
        "found": sim.found,
        "isolated": sim.isolated,
        "bounded": sim.result.bounded,
    }


def table_report(
    sims: tuple[Simulation, ...], groups: tuple[tuple[str, ...], ...], mode: str = "crash"
) -> str:
    width = max([len("component"), *(len(s.faults[0]) for s in sims)])
    lines = [f"{'component':<{width}}  detected  candidates  isolated"]
    for sim in sims:
        lines.append(
            f"{sim.faults[0]:<{width}}  {_yes(sim.detected):<8}  "
            f"{len(sim.result.diagnoses):>10}  {_yes(sim.isolated)}"
        )
    detected = sum(s.detected for s in sims)
    isolated = sum(s.isolated for s in sims)
    lines.append("")
    lines.append(
        f"{detected}/{len(sims)} faults detected, {isolated}/{len(sims)} isolated (mode: {mode})"
    )
    if groups:
        lines.append("ambiguity groups (the model cannot tell these components apart):")
        lines.extend(f"  {{{', '.join(g)}}}" for g in groups)
    elif detected == len(sims) == isolated:
        lines.append("ambiguity groups: none, every single fault is told apart from the others")
    else:
        lines.append("ambiguity groups: none (no two single faults share their symptoms)")
    # A detected fault that is not isolated without a group: its other candidates are not
    # single faults of this mode (several components together, or hardware in output mode).
    grouped = {c for g in groups for c in g}
    alone = [s for s in sims if s.detected and not s.isolated and s.faults[0] not in grouped]
    for s in alone:
        others = [d for d in s.result.diagnoses if d != s.faults]
        shown = " | ".join("{" + ", ".join(d) + "}" for d in others[:4])
        more = f" and {len(others) - 4} more" if len(others) > 4 else ""
        lines.append(
            f"not isolated: {s.faults[0]}: its symptoms are explained as well by {shown}{more}"
        )
    if any(s.result.bounded for s in sims):
        lines.append("note: the search was bounded by --max-card; the counts may be incomplete")
    undetected = [s.faults[0] for s in sims if not s.detected]
    if undetected:
        lines.append(
            f"undetected (no observer sees a symptom; add observers): {', '.join(undetected)}"
        )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    require_json_for_good(args, "simulate")
    theory = load_theory(args.model)
    if args.all_single_faults:
        sims = all_single_faults(theory, args.max_card, args.mode)
        groups = ambiguity_groups(sims)
        if args.json:
            doc = {
                "mode": args.mode,
                "components": [
                    {
                        "component": s.faults[0],
                        "detected": s.detected,
                        "candidates": len(s.result.diagnoses),
                        "isolated": s.isolated,
                        "diagnoses": [list(d) for d in s.result.diagnoses],
                    }
                    for s in sims
                ],
                "ambiguity_groups": [list(g) for g in groups],
            }
            print(json_text(doc, args))
        else:
            print(table_report(sims, groups, args.mode))
        return 0
    sim = simulate(theory, args.fault, args.max_card, args.mode)
    text = json_text(single_json(sim, args.with_good), args) if args.json else None
    print(text or single_report(sim))
    return 0
