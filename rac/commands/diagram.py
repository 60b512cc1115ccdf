"""``racc diagram``: the architecture as a reviewer or an operator needs to see it.

The drawing itself is :func:`rac.targets.dot.emit_diagram` (pure); this command loads the
model, runs the coverage analysis (``rac.analysis``), turns a diagnosis, observations, a
replay's moment or the live ``/diagnosis`` into a :class:`~rac.targets.coverage.Health`, and
writes the file in the format its suffix names (docs/diagrams.md).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rac.commands.common import add_command, count, load_and_compile, write_file_atomically
from rac.commands.diagnose import add_observation_options, observations
from rac.errors import Diagnostic, RacError

if TYPE_CHECKING:
    from rac.diagnosis import Theory
    from rac.pipeline import Compiled
    from rac.replay.timeline import Timeline
    from rac.targets.coverage import Health

# What Graphviz writes for each suffix; .dot and .gv are the DOT text itself.
FORMATS = {".svg": "svg", ".png": "png", ".pdf": "pdf", ".jpg": "jpg", ".jpeg": "jpg"}
# The self-contained page (rac.targets.html): Graphviz's SVG with racc's pan/zoom/search.
HTML_SUFFIXES = (".html", ".htm")
DOT_SUFFIXES = (".dot", ".gv")
# The coverage analysis costs one propagation per fault and mode: 0.05 s at 30 nodes, 5 s
# at 300, 80 s at 1,000 (docs/diagrams.md).  Above this many nodes it runs only when asked.
ANALYSIS_UP_TO_NODES = 300
# racc compile marks them on architecture.dot up to this many nodes: the analysis took 0.3 s
# of CPU at 100 nodes and 3 s at 300 (bench/compile.py's generator), which would have
# multiplied a 300-node compile's time by four.  Above it the caption says "not analysed".
COMPILE_ANALYSIS_UP_TO_NODES = 100
RENDER_TIMEOUT_S = 300


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "diagram",
        "draw the architecture: namespaces, observer coverage, a focus, a diagnosis",
        "Draw MODEL (.ram or ram/1 .json) for review: nodes clustered by namespace, topics "
        "only one node touches and no observer watches folded into a count on the node, "
        "infrastructure topics (/rosout, /tf, /tf_static, /diagnostics, /parameter_events) "
        "shown only when observed, what watches each node and topic, and the components "
        "whose faults no observer detects (the analysis of racc analyze) outlined in red.  "
        "--diagnosis, --obs or --live colour a diagnosis on the drawing.  The suffix of "
        "FILE picks the format: .dot (no Graphviz needed), .svg, .png, .pdf, or .html (the "
        "SVG with pan, zoom, search and tooltips; opens without a network).  Without -o the "
        "DOT text goes to standard output.  See docs/diagrams.md.",
        "  racc diagram models/tedusar.ram -o tedusar.svg\n"
        "  racc diagram models/warehouse.ram --focus /robot_41/localization/amcl --depth 1 "
        "-o amcl.svg\n"
        "  racc diagram models/warehouse.ram -o warehouse.html\n"
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
    parser.add_argument(
        "--focus",
        metavar="NAME",
        help="draw only this node, hardware or topic and its neighbourhood (default: all)",
    )
    parser.add_argument(
        "--depth",
        metavar="N",
        type=_depth,
        default=1,
        help="with --focus: node-to-node hops drawn upstream and downstream (default: 1)",
    )
    parser.add_argument(
        "--summary",
        action="store_true",
        help="one box per namespace (default: only above "
        f"{_summary_nodes()} nodes, as racc compile does)",
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
    parser.add_argument(
        "--max-card",
        metavar="K",
        type=_depth,
        default=3,
        help="diagnose --obs with at most K faulty components (default: 3)",
    )
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


def theory_of(compiled: Compiled) -> Theory:
    from rac.diagnosis import Theory

    return Theory(
        clauses=compiled.rbm,
        props=compiled.props,
        components=compiled.components,
        model=compiled.model,
    )


def run(args: argparse.Namespace) -> int:
    from rac.targets.dot import SUMMARY_ABOVE_NODES, View, emit_diagram

    started = time.perf_counter()
    suffix = check_suffix(args.output)
    compiled = load_and_compile(args.model, quiet=args.quiet)
    model = compiled.model
    if args.focus is not None:
        check_focus(compiled, args.focus)
    summary = not args.everything and args.focus is None
    summary = summary and (args.summary or len(model.nodes) > SUMMARY_ABOVE_NODES)
    theory = theory_of(compiled)
    health = _health(args, compiled, theory)
    undetected = None
    if args.analysis == "yes" or (args.analysis == "auto" and not summary):
        drawn = len(model.nodes)
        if args.analysis == "yes" or drawn <= ANALYSIS_UP_TO_NODES or args.focus is not None:
            undetected = _undetected(theory, quiet=args.quiet)
    view = View(
        everything=args.everything,
        focus=args.focus,
        depth=args.depth,
        summary=summary,
        undetected=undetected,
        health=health,
    )
    text = emit_diagram(model, compiled.observers, view)
    write_diagram(args.output, text, suffix, f"robot {model.name.value}")
    if not args.quiet and args.output:
        took = time.perf_counter() - started
        print(f"wrote {args.output} ({count(len(model.nodes), 'node')}, {took:.2f} s)")
    elif not args.output:
        sys.stdout.write(text)
    return 0


def check_suffix(output: str | None) -> str:
    if output is None:
        return ".dot"
    suffix = Path(output).suffix.lower()
    if suffix not in DOT_SUFFIXES and suffix not in FORMATS and suffix not in HTML_SUFFIXES:
        known = ", ".join([*DOT_SUFFIXES, *FORMATS, *HTML_SUFFIXES])
        raise RacError(
            [
                Diagnostic(
                    "RAC068",
                    f"{output}: the suffix names no diagram format",
                    hint=f"end the file name in one of {known}",
                )
            ]
        )
    return suffix


def write_diagram(output: str | None, text: str, suffix: str, title: str = "architecture") -> None:
    """``text`` (DOT) to ``output``, rendered by Graphviz unless the suffix is .dot/.gv; an
    .html page is the SVG in racc's viewer, titled ``title``."""
    if output is None:
        return
    if suffix in DOT_SUFFIXES:
        write_file_atomically(Path(output), text)
        return
    if suffix in HTML_SUFFIXES:
        from rac.targets.html import emit_html

        svg = render(text, "svg", output).decode("utf-8")
        write_file_atomically(Path(output), emit_html(svg, title))
        return
    write_file_atomically(Path(output), render(text, FORMATS[suffix], output))


def render(text: str, fmt: str, output: str) -> bytes:
    dot = shutil.which("dot")
    if dot is None:
        raise RacError(
            [
                Diagnostic(
                    "RAC065",
                    f"{output}: drawing this format needs Graphviz's dot, which is not installed",
                    hint="install Graphviz (Debian/Ubuntu: apt-get install graphviz), or write "
                    "a .dot file and render it elsewhere",
                )
            ]
        )
    done = run_dot(dot, text, fmt, RENDER_TIMEOUT_S)
    if done.returncode != 0:
        why = done.stderr.decode(errors="replace").strip()
        raise RacError(
            [
                Diagnostic(
                    "RAC065",
                    f"{output}: Graphviz's dot failed: {why}",
                    hint="write a .dot file and report the failure with it",
                )
            ]
        )
    return done.stdout


def run_dot(dot: str, text: str, fmt: str, timeout: float) -> subprocess.CompletedProcess[bytes]:
    """Graphviz's ``dot -TFMT`` of ``text``, once more with ``newrank`` if it fails.

    dot's classic ranking fails on some graphs with clusters ("trouble in init_rank"; a
    300-node robot in 37 namespaces does); ``newrank`` ranks them, with a layout that is
    often wider, so it is the second choice only.
    """
    data = text.encode("utf-8")
    done = subprocess.run(
        [dot, f"-T{fmt}"], input=data, capture_output=True, timeout=timeout, check=False
    )
    if done.returncode != 0 and b"init_rank" in done.stderr:
        done = subprocess.run(
            [dot, "-Gnewrank=true", f"-T{fmt}"],
            input=data,
            capture_output=True,
            timeout=timeout,
            check=False,
        )
    return done


def check_focus(compiled: Compiled, name: str) -> None:
    model = compiled.model
    names = [n.name.value for n in model.nodes] + [h.name.value for h in model.hardware]
    names += [t.name.value for t in model.topics]
    if name in names:
        return
    import difflib

    close = difflib.get_close_matches(name, names, n=3, cutoff=0.5)
    hint = f"did you mean {', '.join(close)}?" if close else "give a node, hardware or topic name"
    raise RacError(
        [
            Diagnostic(
                "RAC066",
                f"--focus {name}: the model has no node, hardware or topic so named",
                hint=hint,
            )
        ]
    )


def compile_undetected(
    compiled: Compiled, quiet: bool
) -> tuple[tuple[str, tuple[str, ...]], ...] | None:
    """What ``racc compile`` marks on architecture.dot: the faults no observer detects, up to
    COMPILE_ANALYSIS_UP_TO_NODES nodes."""
    if len(compiled.model.nodes) > COMPILE_ANALYSIS_UP_TO_NODES:
        return None
    return _undetected(theory_of(compiled), quiet)


def _undetected(theory: Theory, quiet: bool) -> tuple[tuple[str, tuple[str, ...]], ...]:
    from rac.analysis.analyze import undetected
    from rac.analysis.modes import MODES

    if not quiet and sys.stderr.isatty():
        print("analysing which faults the observers detect…", end="\r", file=sys.stderr)
    found = undetected(theory, MODES)
    if not quiet and sys.stderr.isatty():
        print(" " * 50, end="\r", file=sys.stderr)
    return tuple(sorted(found.items()))


def _health(args: argparse.Namespace, compiled: Compiled, theory: Theory) -> Health | None:
    from rac.targets.coverage import Health

    literals = observations(args, theory) if args.sources else ()
    observed = tuple((lit.atom, lit.positive) for lit in literals)
    if args.live:
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


def diagnosis_title(diagnoses: Sequence[Sequence[str]], consistent: bool, what: str) -> str:
    if consistent:
        return f"{what}: consistent, no fault"
    if not diagnoses:
        return f"{what}: no diagnosis explains them"
    shown = " | ".join("{" + ", ".join(d) + "}" for d in diagnoses[:4])
    more = f" (+{len(diagnoses) - 4} more)" if len(diagnoses) > 4 else ""
    return f"{what}: minimal diagnoses {shown}{more}"


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
        raise RacError(
            [
                Diagnostic(
                    "RAC067",
                    f"--diagnosis {text}: "
                    + (f"no component named {', '.join(unknown)}" if unknown else "names nothing"),
                    hint="name nodes or hardware of the model, comma-separated",
                )
            ]
        )
    return tuple(known[n] for n in names)


def replay_health(timeline: Timeline, at: float) -> Health:
    """What a replay had observed and diagnosed at ``at`` seconds."""
    from rac.logic import NEG_PREFIX, parse_atom
    from rac.replay.timeline import DiagnosisRecord, ObservationRecord
    from rac.targets.coverage import Health

    diagnoses: tuple[tuple[str, ...], ...] = ()
    held: dict[Any, bool] = {}
    for record in timeline.records:
        if record.t > at:
            break
        if isinstance(record, DiagnosisRecord):
            diagnoses = record.diagnoses
        elif isinstance(record, ObservationRecord):
            positive = not record.literal.startswith(NEG_PREFIX)
            held[parse_atom(record.literal.removeprefix(NEG_PREFIX))] = positive
    bad = sum(1 for v in held.values() if not v)
    what = f"replay at {at:g} s, {len(held)} observations, {bad} bad"
    title = diagnosis_title(diagnoses, not diagnoses, what)
    return Health(title, diagnoses, tuple(held.items()))


def draw_health(compiled: Compiled, at: float, timeline: Timeline, output: str) -> None:
    """``racc replay --diagram-at``: the architecture as the replay saw it ``at`` seconds in."""
    from rac.targets.dot import View, emit_diagram

    view = View(health=replay_health(timeline, at))
    write_diagram(
        output, emit_diagram(compiled.model, compiled.observers, view), check_suffix(output)
    )
