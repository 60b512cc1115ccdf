"""``racc analyze``: which faults the observers detect and tell apart, per fault mode."""

from __future__ import annotations

import argparse
from typing import Any

from rac.analysis.analyze import Analysis, analyze, flow_graph
from rac.commands.common import add_command, count, json_text
from rac.diagnosis.modes import MODES
from rac.ir import Model
from rac.load.theory import load_theory
from rac.targets.dot import quote


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "analyze",
        "diagnosability: detectable faults, ambiguity groups, propagation cones",
        "For every component and fault mode (crash, output, silent-hardware), predict what "
        "the observers report, and decide under the single-fault assumption whether the fault "
        "is detected and which single faults explain the report (its ambiguity group).  "
        "Prints the scores of the model (detectable %, isolable %, mean group size) and, per "
        "fault, its symptoms and its fault-propagation cone (the topics it can reach).  "
        "--double also injects every pair of faults.  --dot draws the data flow with each "
        "ambiguity group in its own colour.",
        "  racc analyze models/pioneer.ram --mode output\n"
        "  racc analyze models/tedusar.ram --json\n"
        "  racc analyze models/tedusar.ram --mode output --dot > groups.dot",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram, a ram/1 .json or a model.yaml")
    parser.add_argument(
        "--mode",
        choices=MODES,
        action="append",
        help="a fault mode to analyse (repeatable; default: every mode the model allows)",
    )
    parser.add_argument("--double", action="store_true", help="also inject every pair of faults")
    out = parser.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print JSON")
    out.add_argument("--dot", action="store_true", help="print a Graphviz diagram of the groups")
    parser.set_defaults(run=run)


def analyses(path: str, modes: list[str] | None, double: bool) -> list[Analysis]:
    theory = load_theory(path)
    if modes is None:
        modes = list(MODES) if theory.model is not None else ["crash"]
    return [analyze(theory, m, double, path) for m in dict.fromkeys(modes)]


def text_report(a: Analysis) -> str:
    lines = [
        f"{a.model}: mode {a.mode}, {count(len(a.faults), 'fault')}",
        f"  detectable {a.detectable}/{len(a.faults)} ({a.detectable_pct:.0f} %), "
        f"isolable {a.isolable}/{len(a.faults)} ({a.isolable_pct:.0f} %), "
        f"mean group size {a.mean_group:.2f}",
    ]
    width = max([9, *(len(f.component) for f in a.faults)])
    lines.append(f"  {'component':<{width}}  detected  isolated  group / cone")
    for f in a.faults:
        if not f.detectable:
            what = "no symptom"
        elif not f.found:
            what = "blamed on " + ", ".join(f.candidates or ("(nothing single)",))
        else:
            what = "{" + ", ".join(f.candidates) + "}"
        cone = ", ".join(f.cone) or "-"
        lines.append(
            f"  {f.component:<{width}}  {'yes' if f.detectable else 'no':<8}  "
            f"{'yes' if f.isolable else 'no':<8}  {what}; cone: {cone}"
        )
    if a.groups:
        lines.append("  ambiguity groups:")
        lines.extend("    {" + ", ".join(g) + "}" for g in a.groups)
    else:
        lines.append("  ambiguity groups: none")
    undetected = [f.component for f in a.faults if not f.detectable]
    if undetected:
        lines.append(f"  undetectable: {', '.join(undetected)}")
    if a.double is not None:
        d = a.double
        lines.append(
            f"  double faults: {d.pairs} pairs, {d.detected} detected, {d.isolated} isolated"
        )
    return "\n".join(lines)


def to_json(a: Analysis) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "mode": a.mode,
        "scores": {
            "faults": len(a.faults),
            "detectable": a.detectable,
            "isolable": a.isolable,
            "detectable_pct": round(a.detectable_pct, 2),
            "isolable_pct": round(a.isolable_pct, 2),
            "mean_group_size": round(a.mean_group, 3),
        },
        "faults": [
            {
                "component": f.component,
                "detectable": f.detectable,
                "isolable": f.isolable,
                "candidates": list(f.candidates),
                "symptoms": list(f.symptoms),
                "cone": list(f.cone),
            }
            for f in a.faults
        ],
        "ambiguity_groups": [list(g) for g in a.groups],
    }
    if a.double is not None:
        doc["double"] = {
            "pairs": a.double.pairs,
            "detected": a.double.detected,
            "isolated": a.double.isolated,
            "ambiguous": [list(p) for p in a.double.ambiguous],
        }
    return doc


PALETTE = ("#8dd3c7", "#ffffb3", "#bebada", "#fb8072", "#80b1d3", "#fdb462", "#b3de69")


def dot_report(model: Model, a: Analysis) -> str:
    """The data flow with each ambiguity group filled in its colour, undetectable dashed."""
    graph = flow_graph(model)
    colour = {c: PALETTE[k % len(PALETTE)] for k, g in enumerate(a.groups) for c in g}
    faults = {f.component: f for f in a.faults}
    lines = [
        f"digraph {quote(model.name.value + ' ' + a.mode)} {{",
        "  rankdir=LR;",
        f"  label={quote(f'{a.mode}: groups filled alike; dashed: undetectable')};",
    ]
    for name in sorted(graph.nodes):
        kind = graph.nodes[name].get("kind", "topic")
        if kind == "topic":
            lines.append(f"  {quote(name)} [label={quote(name[2:])}, shape=note];")
            continue
        style = ["filled"]
        fault = faults.get(name)
        if fault is not None and not fault.detectable:
            style.append("dashed")
        shape = "box" if kind == "hardware" else "ellipse"
        fill = colour.get(name, "white")
        lines.append(
            f"  {quote(name)} [shape={shape}, style={quote(','.join(style))}, "
            f"fillcolor={quote(fill)}];"
        )
    lines.extend(f"  {quote(u)} -> {quote(v)};" for u, v in sorted(graph.edges))
    lines.append("}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    results = analyses(args.model, args.mode, args.double)
    if args.json:
        print(json_text({"model": args.model, "analyses": [to_json(a) for a in results]}, args))
    elif args.dot:
        model = load_theory(args.model).model
        if model is None:
            from rac.errors import Diagnostic, RacError

            raise RacError([Diagnostic("RAC060", "--dot needs a .ram or .json model")])
        print("\n".join(dot_report(model, a) for a in results[:1]))
    else:
        print("\n\n".join(text_report(a) for a in results))
    return 0
