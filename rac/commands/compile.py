"""``racc compile``: derive every artefact of docs/spec.md into one directory."""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, count, load_and_compile
from rac.commands.reports import compile_undetected
from rac.load.drawing import run_dot
from rac.load.output import write_files_atomically
from rac.perf import paused_gc
from rac.targets import (
    DEFAULT_MODEL_SERVER_PACKAGE,
    DEFAULT_OBSERVERS_PACKAGE,
    EmitOptions,
    emit_all,
    targets,
)
from rac.targets.dot import SUMMARY_ABOVE_NODES, summarised

SVG_NOTE = (
    "note: Graphviz 'dot' was not found, so architecture.svg was not written; "
    "install it (Debian/Ubuntu: apt-get install graphviz) or render architecture.dot elsewhere"
)


def register(sub: Any) -> None:
    names = ", ".join(f"{t.filename} ({t.description})" for t in targets())
    parser = add_command(
        sub,
        "compile",
        "compile a model into the diagnosis and repair artefacts",
        f"Compile MODEL (.ram or ram/1 .json) and write into DIR: {names}, and "
        "architecture.svg when Graphviz is installed. "
        "Nothing is written when the model has errors, and DIR is replaced as a whole: all "
        "files change or none does. Files in DIR that racc does not write are kept.",
        "  racc compile models/tedusar.ram -o build/tedusar\n"
        "  racc compile robot.json -o out --ros-package my_observers --no-svg",
    )
    parser.add_argument("model", metavar="MODEL", help="the model: a .ram file or a ram/1 .json")
    parser.add_argument(
        "-o", "--output", metavar="DIR", default="build", help="output directory (default: build)"
    )
    parser.add_argument(
        "--ros-package",
        metavar="PKG",
        help="ROS package holding one executable per observer kind (NObs.py, GObs.py, ...): "
        "observers.launch then starts the dissertation's stack instead of racc's runtime "
        f"(ROS 2 launch file: default {DEFAULT_OBSERVERS_PACKAGE})",
    )
    parser.add_argument(
        "--model-server-package",
        metavar="PKG",
        help="ROS package of diagnosis_model_server.py, for the dissertation's stack "
        f"(default with --ros-package: {DEFAULT_MODEL_SERVER_PACKAGE})",
    )
    parser.add_argument("--no-svg", action="store_true", help="do not render architecture.svg")
    parser.add_argument(
        "--html",
        action="store_true",
        help="also write architecture.html, the SVG with pan, zoom, search and tooltips, "
        "self-contained (needs Graphviz; default: off)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    parser.set_defaults(run=run)


def render_svg(dot_text: str) -> bytes | None:
    """architecture.svg from the DOT text, or None where Graphviz is missing or fails."""
    dot = shutil.which("dot")
    if dot is None:
        return None
    done = run_dot(dot, dot_text, "svg", 120)
    if done.returncode != 0:
        print(
            f"warning: dot failed: {done.stderr.decode(errors='replace').strip()}", file=sys.stderr
        )
        return None
    return done.stdout


def run(args: argparse.Namespace) -> int:
    # One pause of the cyclic GC over the whole compile, not one per step: each step's
    # pause ends in a collection of everything the step allocated (the whole IR, on a large
    # model), while here the outputs are written and dropped before the collector resumes,
    # so it has next to nothing left to look at (see rac.perf).
    with paused_gc():
        return _compile(args)


def _compile(args: argparse.Namespace) -> int:
    compiled = load_and_compile(args.model, quiet=args.quiet)
    options = EmitOptions(
        observers_package=args.ros_package,
        model_server_package=args.model_server_package,
        undetected=compile_undetected(compiled, args.quiet),
    )
    files: dict[str, str | bytes] = dict(emit_all(compiled, options))
    if not args.no_svg:
        svg = render_svg(str(files["architecture.dot"]))
        if svg is None:
            if shutil.which("dot") is None and not args.quiet:
                print(SVG_NOTE, file=sys.stderr)
        else:
            files["architecture.svg"] = svg
            if args.html:
                from rac.targets.html import emit_html

                title = f"robot {compiled.model.name.value}"
                files["architecture.html"] = emit_html(svg.decode("utf-8"), title)
    if summarised(compiled.model) and not args.quiet:
        print(
            f"note: {len(compiled.model.nodes):,} nodes (over {SUMMARY_ABOVE_NODES}): "
            "architecture.dot is the summary, one box per namespace; draw the detail with "
            f"racc diagram {args.model} --focus NAME -o FILE.svg (or --all)",
            file=sys.stderr,
        )
    out = Path(args.output)
    owned = [t.filename for t in targets()] + ["architecture.svg", "architecture.html"]
    write_files_atomically(out, files, owned)
    if not args.quiet:
        model = compiled.model
        print(
            f"compiled {model.name.value}: {count(len(model.nodes), 'node')}, "
            f"{count(len(model.hardware), 'hardware')}, "
            f"{count(len(model.topics), 'topic')} -> {count(len(compiled.rbm), 'clause')}, "
            f"{count(len(compiled.observers), 'observer')}"
        )
        for name in sorted(files):
            print(f"  wrote {out / name}")
    return 0
