"""The default diagram of each robot, today's beside another revision's (docs/diagrams.md).

Run:  .venv/bin/python bench/diagram.py [--baseline main] [--repeat 3] [--pictures DIR]

For the bundled models, the newcomer's and the tugger's robots (tests/diagram_robots.py,
tests/tug/tugger.yaml) and synthetic robots of 30, 100 and 300 nodes in one namespace and
in several, each with one hub, it prints for the default view of ``racc diagram`` (the
coverage analysis where racc diagram runs it, up to 300 nodes): the page in points, the
arrows (an arrow with its label is one, a hardware link is one), the crossings between
arrows without a common end and the labels with an arrow through them, both read from
Graphviz's layout (``dot -Tjson``), and the time: building the DOT text (the analysis
included) plus Graphviz's SVG, the best of ``--repeat`` runs each.  The same for the
revision ``--baseline`` (``git archive`` of it, run in a process of its own), so that each
row says before and after.  ``--pictures DIR`` writes every drawing as a PNG to look at.
The machine is shared: times vary by a factor of two between runs.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from diagram_robots import newcomer_robot, synthetic_robot, tugger  # noqa: E402
from drawings import layout, measure  # noqa: E402

from rac.fmt import format_model  # noqa: E402
from rac.ir import Model  # noqa: E402
from rac.load.files import load_model  # noqa: E402

# What racc diagram draws by default, in any revision of racc since the views landed (run
# in a process whose sys.path starts at that revision): the text, and the time to build it.
DEFAULT_VIEW = """
import json, sys, time
from rac.load.files import load_model
from rac.pipeline import compile_model
from rac.diagnosis.theory import theory_of
from rac.analysis.analyze import undetected
from rac.diagnosis.modes import MODES
import rac.targets.dot as dot

out = {}
for name, path, repeat in json.loads(sys.argv[1]):
    best = None
    for _ in range(repeat):
        started = time.perf_counter()
        compiled = compile_model(load_model(path))
        model = compiled.model
        if hasattr(dot, "summarised"):
            summary = dot.summarised(model)
        else:
            summary = len(model.nodes) > dot.SUMMARY_ABOVE_NODES
        marks = None
        if not summary and len(model.nodes) <= 300:  # racc diagram's analysis, auto
            marks = tuple(sorted(undetected(theory_of(compiled), MODES).items()))
        view = dot.View(summary=summary, undetected=marks)
        if hasattr(dot, "draw_diagram"):
            drawing = dot.draw_diagram(model, compiled.observers, view)
            text, kind = drawing.text, drawing.view
        else:  # before issue 37: one detailed view, with topics
            text = dot.emit_diagram(model, compiled.observers, view)
            kind = "summary" if summary else "topics"
        took = time.perf_counter() - started
        best = took if best is None else min(best, took)
    out[name] = {"text": text, "seconds": best, "view": kind}
print(json.dumps(out))
"""


def robots() -> list[tuple[str, Model]]:
    found: list[tuple[str, Model]] = [
        (f"{name} (bundled)", load_model(ROOT / "models" / f"{name}.ram"))
        for name in ("tedusar", "pioneer", "warehouse")
    ]
    found += [("newcomer", newcomer_robot()), ("tugger (the real robot's shape)", tugger())]
    for nodes, spaces in ((30, 1), (30, 4), (100, 1), (100, 6), (300, 1), (300, 12)):
        where = "1 namespace" if spaces == 1 else f"{spaces} namespaces"
        found.append((f"synthetic {nodes}, {where}", synthetic_robot(nodes, spaces)))
    return found


@dataclass(frozen=True, slots=True)
class Row:
    width: float
    height: float
    arrows: int
    crossings: int
    on_labels: int
    seconds: float
    view: str


def render_seconds(text: str, repeat: int) -> float:
    dot = shutil.which("dot")
    assert dot is not None
    best = float("inf")
    for _ in range(repeat):
        started = time.perf_counter()
        subprocess.run([dot, "-Tsvg"], input=text.encode(), capture_output=True, check=True)
        best = min(best, time.perf_counter() - started)
    return best


def rows_of(
    source: Path, models: list[tuple[str, Path]], repeat: int, pictures: Path | None, tag: str
) -> dict[str, Row]:
    """Every model's default view as the racc at ``source`` draws it."""
    jobs = json.dumps([(name, str(path), repeat) for name, path in models])
    done = subprocess.run(
        [sys.executable, "-c", DEFAULT_VIEW, jobs],
        capture_output=True,
        check=True,
        cwd=source,
        env={"PYTHONPATH": str(source), "PATH": "/usr/bin:/bin"},
    )
    found = json.loads(done.stdout)
    rows = {}
    for k, (name, _) in enumerate(models):
        text = found[name]["text"]
        seen = measure(layout(text))
        seconds = found[name]["seconds"] + render_seconds(text, repeat)
        rows[name] = Row(
            seen.width,
            seen.height,
            seen.arrows,
            seen.crossings,
            seen.on_labels,
            seconds,
            found[name]["view"],
        )
        if pictures is not None:
            png = pictures / f"{k:02d}-{tag}.png"
            dot = shutil.which("dot")
            assert dot is not None
            subprocess.run([dot, "-Tpng", "-o", str(png)], input=text.encode(), check=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main", help="the revision to compare with")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--pictures", type=Path, help="write each drawing as DIR/NN-WHEN.png")
    args = parser.parse_args()
    if shutil.which("dot") is None:
        sys.exit("bench/diagram.py needs Graphviz's dot")
    if args.pictures is not None:
        args.pictures.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        models = []
        for k, (name, model) in enumerate(robots()):
            path = work / f"robot{k}.ram"
            path.write_text(format_model(model), "utf-8")
            models.append((name, path))
        before_src = work / "before"
        before_src.mkdir()
        archive = subprocess.run(
            ["git", "-C", str(ROOT), "archive", args.baseline, "rac"],
            capture_output=True,
            check=True,
        )
        subprocess.run(["tar", "-x", "-C", str(before_src)], input=archive.stdout, check=True)
        before = rows_of(before_src, models, args.repeat, args.pictures, "before")
        after = rows_of(ROOT, models, args.repeat, args.pictures, "after")
    print(
        f"{'robot':<34} {'':>6} {'view':>7} {'page (pt)':>15} {'arrows':>6} "
        f"{'cross':>6} {'labels':>6} {'time':>7}"
    )
    for name, _ in models:
        for when, row in (("before", before[name]), ("after", after[name])):
            page = f"{row.width:,.0f} × {row.height:,.0f}"
            print(
                f"{name if when == 'before' else '':<34} {when:>6} {row.view:>7} {page:>15} "
                f"{row.arrows:>6} {row.crossings:>6} {row.on_labels:>6} {row.seconds:>6.2f}s"
            )
    print(
        f"\nbefore: {args.baseline}; labels: labels with another arrow through them; time: "
        f"DOT text (with the coverage analysis up to 300 nodes) and dot -Tsvg, best of "
        f"{args.repeat}"
    )


if __name__ == "__main__":
    main()
