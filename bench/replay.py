"""Benchmark ``racc replay`` and ``racc evaluate`` on the pioneer robot of §10.2.

Synthesises (once, into a scratch directory) two fault-free training runs and two test
runs with the thesis schedule, DURATION seconds each, then times, as a user runs them:

- ``racc replay models/pioneer.ram TEST1``: the bar is at least 20x faster than real time;
- ``racc evaluate --learn-from TRAIN1 TRAIN2 --base models/pioneer.ram -Q 0.9 0.8 0.5
  --alpha 10 2.5 0.5 --runs TEST1 TEST2``: learning the nine models and replaying both test
  runs through each; the bar is under 2 minutes with 10-minute runs.

    .venv/bin/python bench/replay.py                  # 600 s runs, as the bars are set
    .venv/bin/python bench/replay.py --duration 300 --keep /tmp/pioneer-runs
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PIONEER = ROOT / "models" / "pioneer.ram"
RACC = [sys.executable, "-m", "rac"]


def racc(*args: str) -> tuple[float, str]:
    started = time.perf_counter()
    done = subprocess.run([*RACC, *args], capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - started
    if done.returncode != 0:
        sys.exit(f"racc {' '.join(args)} failed ({done.returncode}):\n{done.stderr}")
    return elapsed, done.stdout


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=600.0, help="seconds per run")
    parser.add_argument("--keep", metavar="DIR", help="write the runs here and keep them")
    args = parser.parse_args()
    scratch = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="racc-bench-"))
    scratch.mkdir(parents=True, exist_ok=True)
    d = f"{args.duration:g}"
    try:
        runs = {
            "train1": ["--seed", "1"],
            "train2": ["--seed", "2"],
            "test1": ["--seed", "3", "--schedule", "thesis"],
            "test2": ["--seed", "4", "--schedule", "thesis"],
        }
        for name, extra in runs.items():
            bag = scratch / f"{name}.bag"
            if not bag.exists():
                racc("synth", str(PIONEER), "-o", str(bag), "--duration", d, "-q", *extra)
        test1 = str(scratch / "test1.bag")
        best = min(racc("replay", str(PIONEER), test1, "-q")[0] for _ in range(3))
        print(
            f"replay  pioneer, {d} s run: {best:.2f} s wall (best of 3), "
            f"{args.duration / best:.0f}x real time (bar: at least 20x)"
        )
        elapsed, _ = racc(
            "evaluate",
            "--learn-from", str(scratch / "train1.bag"), str(scratch / "train2.bag"),
            "--base", str(PIONEER),
            "-Q", "0.9", "0.8", "0.5", "--alpha", "10", "2.5", "0.5",
            "--runs", test1, str(scratch / "test2.bag"), "-q",
        )  # fmt: skip
        print(
            f"evaluate 9 learned models x 2 test runs of {d} s: {elapsed:.1f} s wall "
            "(bar: under 120 s for 600 s runs)"
        )
    finally:
        if not args.keep:
            shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    main()
