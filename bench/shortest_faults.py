"""The shortest fault of each kind that replay detects with default parameters (issue 23).

For each fault kind and duration D, ``racc synth`` writes RUNS recordings of
models/tedusar.ram (50 s, seeds 1..RUNS) with the fault at 20 s for D seconds, and ``racc
evaluate`` replays them through the hand-written model (grace 5 s, the default).  A row
gives how many of the runs had the fault reported, and whether any false positive came;
``--latency`` adds the range of the time from the fault's start to the first diagnosis
naming its culprit.

    .venv/bin/python bench/shortest_faults.py                 # ~10 min on a shared machine
    .venv/bin/python bench/shortest_faults.py --runs 5 --durations 2 3 4
    .venv/bin/python bench/shortest_faults.py --kinds crash --durations 3 --runs 10 --latency
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "models" / "tedusar.ram"
TARGETS = {
    "crash": "jaguar_teleop_node",
    "trip": "hokuyo",
    "freq": "/pose",
    "slip": "/pose",
    "cpu": "jaguar_node",
    "mem": "hector_mapping",
}
START_S = 20.0
LENGTH_S = 50.0


def racc(*args: str) -> str:
    done = subprocess.run(
        [sys.executable, "-m", "rac", *args], capture_output=True, text=True, check=False
    )
    if done.returncode != 0:
        sys.exit(f"racc {' '.join(args)} failed ({done.returncode}):\n{done.stderr}")
    return done.stdout


def detected(scratch: Path, kind: str, duration: float, runs: int) -> tuple[int, int, list[float]]:
    """(runs whose fault was reported, false positives, the report latencies) for one kind
    and duration."""
    bags = []
    for seed in range(1, runs + 1):
        bag = scratch / f"{kind}_{duration:g}_{seed}.bag"
        fault = f"{kind}@{START_S:g}+{duration:g}:{TARGETS[kind]}"
        racc("synth", str(MODEL), "-o", str(bag), "--duration", f"{LENGTH_S:g}", "--seed",
             str(seed), "--fault", fault, "--force", "-q")  # fmt: skip
        bags.append(str(bag))
    doc = json.loads(racc("evaluate", "--models", str(MODEL), "--runs", *bags, "--json"))
    model = doc["models"][0]
    reported = sum(1 for o in model["outcomes"] if o["reported"])
    latencies = [o["first"] - START_S for o in model["outcomes"] if o["reported"]]
    return reported, len(model["false_positives"]), latencies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3, help="recordings per cell (default 3)")
    parser.add_argument(
        "--durations", type=float, nargs="+", default=[1, 2, 3, 4, 6, 10], help="seconds"
    )
    parser.add_argument("--kinds", nargs="+", default=list(TARGETS), choices=list(TARGETS))
    parser.add_argument(
        "--latency", action="store_true", help="add the report latencies (default: off)"
    )
    args = parser.parse_args()
    scratch = Path(tempfile.mkdtemp(prefix="racc-shortest-"))
    print("| kind | target | " + " | ".join(f"{d:g} s" for d in args.durations) + " |")
    print("|---|---|" + "---|" * len(args.durations))
    for kind in args.kinds:
        cells = []
        for d in args.durations:
            found, fps, late = detected(scratch, kind, d, args.runs)
            cell = f"{found}/{args.runs}" + (f" ({fps} FP)" if fps else "")
            if args.latency and late:
                cell += f" ({min(late):.1f}-{max(late):.1f} s)"
            cells.append(cell)
        print(f"| {kind} | `{TARGETS[kind]}` | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
