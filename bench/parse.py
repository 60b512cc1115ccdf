"""Parsing benchmark: the fast parser (rac/fastparse.py) against Lark alone.

Run with ``.venv/bin/python bench/parse.py`` (``--sizes 1000 10000`` to pick sizes,
``--repeat N`` to keep the best of N runs).

The models are bench/compile.py's synthetic robots, written as ``.ram`` by the formatter.
For each size it prints, in CPU time with the cyclic GC paused (as ``racc compile`` runs):

- ``parse_ram`` as racc runs it (the fast parser, Lark only when it hands over), and with
  Lark alone (``rac.parse._parse_with_lark``, comments attached the same way);
- a whole compile (parse, validate, derive, every output but the SVG) with each, the figure
  the fast parser exists for: issue 24 keeps a fast path only if Lark alone cannot compile
  10,000 nodes within 2.5 s.

Figures are printed, never asserted; the machine is shared, so repeat and compare runs taken
at the same time.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench/compile.py

from compile import synthetic_model

from rac.fmt import format_model
from rac.ir import Model
from rac.parse import _attach_comments, _parse_with_lark, parse_ram
from rac.perf import paused_gc
from rac.pipeline import compile_model
from rac.targets import EmitOptions, emit_all


def lark_alone(text: str, path: str) -> Model:
    """What parse_ram returns when Lark reads the text (no fast path)."""
    with paused_gc():
        model, comments = _parse_with_lark(text, path)
        return replace(_attach_comments(model, comments), source=text)


def compile_with(read: Callable[[str, str], Model], text: str, path: str) -> None:
    emit_all(compile_model(read(text, path)), EmitOptions())


def best_cpu(fn: Callable[[], object], repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        with paused_gc():
            start = time.process_time()
            fn()
            best = min(best, time.process_time() - start)
    return best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--repeat", type=int, default=3, help="best of N runs (default 3)")
    args = parser.parse_args()
    print(f"best of {args.repeat}, CPU time, cyclic GC paused")
    lark_alone(format_model(synthetic_model(20)), "warm.ram")  # grammar load: once a process
    for size in args.sizes:
        text = format_model(synthetic_model(size))
        path = f"synthetic{size}.ram"
        assert repr(parse_ram(text, path)) == repr(lark_alone(text, path))
        print(f"{size:>6} nodes ({len(text) / 1024:.0f} KiB):")
        readers: dict[str, Callable[[str, str], Model]] = {
            "fast parser": parse_ram,
            "Lark alone": lark_alone,
        }
        for label, read in readers.items():
            parse = best_cpu(partial(read, text, path), args.repeat)
            compile_time = best_cpu(partial(compile_with, read, text, path), args.repeat)
            print(f"    {label:<12} parse {parse:7.3f} s   compile {compile_time:7.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
