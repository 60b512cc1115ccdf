"""``racc diagram``: the architecture as a reviewer or an operator needs to see it.

The drawing itself is :func:`rac.targets.dot.emit_diagram` (pure); this command loads the
model, runs the coverage analysis (``rac.analysis``), turns a diagnosis, observations, a
replay's moment or the live ``/diagnosis`` into a :class:`~rac.targets.coverage.Health`, and
writes the file in the format its suffix names (docs/diagrams.md).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import TYPE_CHECKING, Any

from rac.commands.common import add_command, count, load_and_compile
from rac.commands.options import add_max_card_option, add_observation_options
from rac.commands.reports import diagnosis_title, undetected_faults
from rac.diagnosis.theory import theory_of
from rac.errors import Diagnostic, RacError, closest
from rac.load.drawing import (
    check_suffix,
    write_diagram,
)
from rac.load.observations import read_observations

if TYPE_CHECKING:
    from rac.diagnosis import Theory
    from rac.pipeline import Compiled
    from rac.targets.coverage import Health
    from rac.targets.diagram import Drawing

# The coverage analysis costs one propagation per fault and mode: 0.05 s at 30 nodes, 5 s
# at 300, 80 s at 1,000 (docs/diagrams.md).  Above this many nodes it runs only when asked.
ANALYSIS_UP_TO_NODES = 300


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "diagram",
        "draw the architecture: data flow, observer coverage, a focus, a diagnosis",
        "Draw MODEL (.ram or ram/1 .json) for review, laid out by data flow (sources first, "
        "a loop's arrow back into a driver drawn against the flow): up to "
        f"{_node_view_nodes()} nodes every topic on its arrow or box, above that one arrow "
        "per pair of nodes with hubs drawn beside the nodes they talk to, and above "
        f"{_summary_nodes()} nodes in several namespaces (300 in one) one box per namespace "
        "(--focus opens one).  Topics only one node touches and no observer watches are "
        "folded into a count on the node, infrastructure topics (/rosout, /tf, /tf_static, "
        "/diagnostics, /parameter_events) shown only when observed; what watches each node "
        "and topic is "
        "shown, and the components whose faults no observer detects (the analysis of racc "
        "analyze) are outlined in red.  "
        "--diagnosis, --obs or --live colour a diagnosis on the drawing.  The suffix of "
        "FILE picks the format: .dot (no Graphviz needed), .svg, .png, .pdf, or .html (the "
        "SVG with pan, zoom, search and tooltips; opens without a network).  Without -o the "
        "DOT text goes to standard output.  See docs/diagrams.md.",
        "  racc diagram models/tedusar.ram -o tedusar.svg\n"
        "  racc diagram models/warehouse.ram --focus /robot_41/localization/amcl --depth 1 "
        "-o amcl.svg\n"
        "  racc diagram models/warehouse.ram -o warehouse.html\n"
        "  racc diagram models/warehouse.ram --focus /robot_41/localization -o loc.svg\n"
        "  racc diagram models/tedusar.ram --diagnosis jaguar_node -o fault.svg\n"
        "  racc diagram models/tedusar.ram --obs 'not ok(pose)' --obs 'running(jaguar_node)' "
        "-o fault.png\n"
        "  racc diagram robot.ram --live -o now.svg",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram file or a ram/1 .json")
    parser.add_argument(
        "-o",
        "--output",
        metavar="FILE",
        help="the file to write; its suffix picks the format: .dot, .svg, .png, .pdf, .html "
        "(default: DOT on standard output)",
    )
    parser.add_argument(
        "--all",
        action="store_true",
        dest="everything",
        help="draw every topic and node: fold nothing, never summarise (default: fold)",
    )
    level = parser.add_mutually_exclusive_group()
    level.add_argument(
        "--nodes",
        action="store_const",
        const="nodes",
        dest="level",
        help="one arrow per pair of nodes, labelled with its topic or how many it carries, "
        "hubs drawn beside the nodes they talk to (default above "
        f"{_node_view_nodes()} drawn nodes)",
    )
    level.add_argument(
        "--topics",
        action="store_const",
        const="topics",
        dest="level",
        help="every drawn topic on its own arrow or box, as the dissertation's Figure 3.1 "
        f"(default up to {_node_view_nodes()} drawn nodes, and with --all)",
    )
    parser.add_argument(
        "--focus",
        metavar="NAME",
        help="draw only this node, hardware, topic or namespace and its neighbourhood "
        "(default: all); a namespace's neighbours are drawn as namespace boxes",
    )
    parser.add_argument(
        "--depth",
        metavar="N",
        type=_depth,
        help="with --focus: node-to-node hops drawn upstream and downstream (default: 1 "
        "around a node, hardware or topic, 0 around a namespace)",
    )
    parser.add_argument(
        "--summary",
        action="store_true",
        help="one box per namespace (default: above "
        f"{_summary_nodes()} nodes in two namespaces or more, or 300 in one, as racc compile "
        "does)",
    )
    parser.add_argument(
        "--analysis",
        choices=("auto", "yes", "no"),
        default="auto",
        help="mark the faults no observer detects (racc analyze's analysis); auto: up to "
        f"{ANALYSIS_UP_TO_NODES} nodes drawn (default: auto)",
    )
    parser.add_argument(
        "--diagnosis",
        metavar="C[,C…]",
        action="append",
        help="a minimal diagnosis to colour: its faulty components, comma-separated "
        "(repeatable, one per diagnosis; default: the diagnoses of --obs, if any)",
    )
    add_observation_options(parser)
    add_max_card_option(parser, 3, "diagnose --obs with at most K faulty components", _depth)
    parser.add_argument(
        "--live",
        action="store_true",
        help="colour what the running robot's /diagnosis and /observations say now (reads "
        "them once; needs rospy or rclpy)",
    )
    parser.add_argument(
        "--ros",
        type=int,
        choices=(1, 2),
        help="with --live: ROS 1 or ROS 2 (default: from ROS_VERSION, else what is importable)",
    )
    parser.add_argument(
        "--timeout",
        metavar="S",
        type=float,
        default=5.0,
        help="with --live: seconds to wait for /diagnosis (default: 5)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    parser.set_defaults(run=run)


def _depth(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError("must be 0 or more")
    return value


def _summary_nodes() -> int:
    from rac.targets.dot import SUMMARY_ABOVE_NODES

    return SUMMARY_ABOVE_NODES


def _node_view_nodes() -> int:
    from rac.targets.diagram import NODE_VIEW_ABOVE_NODES

    return NODE_VIEW_ABOVE_NODES


def run(args: argparse.Namespace) -> int:
    from rac.targets.dot import View, draw_diagram, summarised

    started = time.perf_counter()
    suffix = check_suffix(args.output)
    compiled = load_and_compile(args.model, quiet=args.quiet)
    model = compiled.model
    if args.focus is not None:
        check_focus(compiled, args.focus)
    summary = not args.everything and args.focus is None and args.level is None
    summary = summary and (args.summary or summarised(model))
    theory = theory_of(compiled)
    health = _health(args, compiled, theory)
    undetected = None
    if args.analysis == "yes" or (args.analysis == "auto" and not summary):
        drawn = len(model.nodes)
        if args.analysis == "yes" or drawn <= ANALYSIS_UP_TO_NODES or args.focus is not None:
            undetected = undetected_faults(theory, quiet=args.quiet)
    view = View(
        everything=args.everything,
        focus=args.focus,
        depth=args.depth,
        summary=summary,
        level=args.level or "auto",
        undetected=undetected,
        health=health,
    )
    drawing = draw_diagram(model, compiled.observers, view)
    write_diagram(args.output, drawing.text, suffix, f"robot {model.name.value}")
    if not args.quiet and args.output:
        took = time.perf_counter() - started
        print(f"wrote {args.output} ({_what(drawing, len(model.nodes))}, {took:.2f} s)")
    elif not args.output:
        sys.stdout.write(drawing.text)
    return 0


def _what(drawing: Drawing, nodes: int) -> str:
    """``the node view of 31 nodes``, ``the topic view of 7 of 31 nodes``, ``…``."""
    drawn = (
        count(nodes, "node") if drawing.nodes == nodes else f"{drawing.nodes:,} of {nodes:,} nodes"
    )
    kind = {"nodes": "the node view", "topics": "the topic view", "summary": "the summary"}
    return f"{kind[drawing.view]} of {drawn}"


def check_focus(compiled: Compiled, name: str) -> None:
    from rac.targets.diagram.topology import Topology, focus_namespace, namespace

    model = compiled.model
    names = [n.name.value for n in model.nodes] + [h.name.value for h in model.hardware]
    names += [t.name.value for t in model.topics]
    if name in names or focus_namespace(model, Topology(model), name) is not None:
        return
    import difflib

    spaces = {namespace(n.name.value) for n in model.nodes} - {""}
    for space in list(spaces):  # and the namespaces that hold them
        while space := namespace(space):
            spaces.add(space)
    close = difflib.get_close_matches(name, [*names, *sorted(spaces)], n=3, cutoff=0.5)
    hint = (
        f"did you mean {', '.join(close)}?"
        if close
        else "give a node, hardware, topic or namespace name"
    )
    raise RacError(
        [
            Diagnostic(
                "RAC066",
                f"--focus {name}: the model has no node, hardware, topic or namespace so named",
                hint=hint,
            )
        ]
    )


def _health(args: argparse.Namespace, compiled: Compiled, theory: Theory) -> Health | None:
    from rac.targets.coverage import Health

    literals = read_observations(args.sources, theory) if args.sources else ()
    observed = tuple((lit.atom, lit.positive) for lit in literals)
    if args.live:
        # The live half (rac.runtime.status, then rospy or rclpy) loads only for --live.
        from rac.commands.diagram_live import live_health

        live: Health = live_health(args, compiled)
        return live
    if args.diagnosis:
        diagnoses = tuple(_named_diagnosis(compiled, text) for text in args.diagnosis)
        shown = " | ".join(", ".join(d) for d in diagnoses)
        return Health(f"diagnosis: {shown}", diagnoses, observed)
    if not literals:
        return None
    from rac.diagnosis import diagnose

    result = diagnose(theory, literals, args.max_card)
    bad = sum(1 for lit in literals if not lit.positive)
    return Health(
        diagnosis_title(
            result.diagnoses, result.consistent, f"{len(literals)} observations, {bad} bad"
        ),
        result.diagnoses,
        observed,
    )


def _named_diagnosis(compiled: Compiled, text: str) -> tuple[str, ...]:
    from rac.logic import mangle

    model = compiled.model
    known = {mangle(c): c for c in compiled.components}
    for name in [*(n.name.value for n in model.nodes), *(h.name.value for h in model.hardware)]:
        known[name] = name
        known[mangle(name)] = name
    names = tuple(p.strip() for p in text.split(",") if p.strip())
    unknown = [n for n in names if n not in known]
    if unknown or not names:
        fixed = [closest(n, set(known.values())) or n if n in unknown else n for n in names]
        hint = (
            f"did you mean '{','.join(fixed)}'?"
            if fixed != list(names)
            else "name nodes or hardware of the model, comma-separated"
        )
        raise RacError(
            [
                Diagnostic(
                    "RAC067",
                    f"--diagnosis {text}: "
                    + (f"no component named {', '.join(unknown)}" if unknown else "names nothing"),
                    hint=hint,
                )
            ]
        )
    return tuple(known[n] for n in names)
