"""Render times and picture sizes of the diagram views (docs/diagrams.md).

Run:  .venv/bin/python bench/diagram.py [--repeat 3]

For each view: the time to build the DOT text in process (the coverage analysis included
where the view has it), Graphviz's time to render it as SVG and as PNG (the best of
``--repeat`` runs each; the machine is shared, so figures vary), and the PNG's size in pixels.
"""

from __future__ import annotations

import argparse
import shutil
import struct
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from rac.analysis.analyze import undetected  # noqa: E402
from rac.diagnosis.modes import MODES  # noqa: E402
from rac.diagnosis.theory import theory_of  # noqa: E402
from rac.load.files import load_model  # noqa: E402
from rac.pipeline import compile_model  # noqa: E402
from rac.targets.dot import View, emit_diagram  # noqa: E402

TEDUSAR = ROOT / "models" / "tedusar.ram"
WAREHOUSE = ROOT / "models" / "warehouse.ram"
VIEWS: list[tuple[str, Path, dict[str, object]]] = [
    ("tedusar", TEDUSAR, {"analysis": True}),
    ("tedusar --focus hector_mapping", TEDUSAR, {"focus": "hector_mapping", "analysis": True}),
    ("warehouse", WAREHOUSE, {"analysis": True}),
    (
        "warehouse --focus amcl",
        WAREHOUSE,
        {"focus": "/robot_41/localization/amcl", "analysis": True},
    ),
    ("warehouse --summary", WAREHOUSE, {"summary": True}),
    ("warehouse --all", WAREHOUSE, {"everything": True, "analysis": True}),
]


def best(repeat: int, work: object) -> float:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        work()  # type: ignore[operator]
        times.append(time.perf_counter() - started)
    return min(times)


def text_of(path: Path, options: dict[str, object]) -> str:
    compiled = compile_model(load_model(path))
    marks = None
    if options.get("analysis"):
        marks = tuple(sorted(undetected(theory_of(compiled), MODES).items()))
    view = View(
        everything=bool(options.get("everything")),
        focus=options.get("focus"),  # type: ignore[arg-type]
        summary=bool(options.get("summary")),
        undetected=marks,
    )
    return emit_diagram(compiled.model, compiled.observers, view)


def png_size(data: bytes) -> tuple[int, int]:
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def measure(path: Path, options: dict[str, object], repeat: int, dot: str | None) -> str:
    text_s = best(repeat, lambda: text_of(path, options))
    if dot is None:
        return f"{text_s:7.2f}s  (Graphviz not installed)"
    text = text_of(path, options).encode()

    def render(fmt: str) -> bytes:
        done = subprocess.run([dot, f"-T{fmt}"], input=text, capture_output=True, check=True)
        return done.stdout

    svg_s = best(repeat, lambda: render("svg"))
    png_s = best(repeat, lambda: render("png"))
    width, height = png_size(render("png"))
    return f"{text_s:7.2f}s {svg_s:7.2f}s {png_s:7.2f}s  {width} x {height}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    dot = shutil.which("dot")
    print(f"{'view':<32} {'text':>8} {'svg':>8} {'png':>8}  png size")
    for name, path, options in VIEWS:
        print(f"{name:<32} {measure(path, options, args.repeat, dot)}")


if __name__ == "__main__":
    main()
