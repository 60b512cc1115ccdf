"""`racc check` of a model with many `relate` lines on one topic (issue 27).

    .venv/bin/python bench/relations.py [--sizes 5000 10000 20000] [--repeat 3]

The model: one topic with n + 1 fields, one node publishing it, and n relations
``relate /t.f0 ~ /t.fi``.  Checking each relation looks its two fields up in the topic's
field list; that list was rebuilt for every reference, which made the check quadratic
(13.4 s at 20,000 relations).  Prints the wall-clock and CPU time of the whole command (a
fresh ``racc check`` process, start-up included), each the best of ``--repeat`` runs; CPU time
is the steadier figure on a shared machine.  Figures are printed, never asserted; the goal is
under 1 s at 20,000.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def relations_model(n: int) -> str:
    fields = ", ".join(f"f{i}" for i in range(n + 1))
    lines = [
        "robot relations",
        f"topic /t : std_msgs/Float64 {{ {fields} }} @ 10 Hz",
        "node n { publishes /t }",
    ]
    lines += [f"relate /t.f0 ~ /t.f{i}" for i in range(1, n + 1)]
    return "\n".join(lines) + "\n"


def check_seconds(path: Path) -> tuple[float, float]:
    """Wall-clock and CPU (user + system) seconds of one ``racc check`` process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    began = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "rac", "check", str(path)], capture_output=True, text=True
    )
    elapsed = time.perf_counter() - began
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"racc check {path} failed:\n{done.stderr[-2000:]}")
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return elapsed, cpu


def best(path: Path, repeat: int) -> tuple[float, float]:
    runs = [check_seconds(path) for _ in range(repeat)]
    return min(w for w, _ in runs), min(c for _, c in runs)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[5000, 10000, 20000])
    parser.add_argument("--repeat", type=int, default=3, help="best of N runs (default 3)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="racc-relations-") as tmp:
        empty = Path(tmp) / "empty.ram"
        empty.write_text(relations_model(1), encoding="utf-8")
        wall, cpu = best(empty, args.repeat)
        print(f"racc check of      1 relation:  {wall:6.2f} s wall, {cpu:6.2f} s CPU (start-up)")
        first = None
        for n in args.sizes:
            path = Path(tmp) / f"relations_{n}.ram"
            path.write_text(relations_model(n), encoding="utf-8")
            wall, cpu = best(path, args.repeat)
            first = first or cpu
            ratio = f"CPU {cpu / first:4.1f}x the first size"
            times = f"{wall:6.2f} s wall, {cpu:6.2f} s CPU"
            print(f"racc check of {n:>6,} relations: {times} ({ratio})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
