"""Regenerate the §10.2 reproduction in docs/evaluation.md (the one command it names).

On models/pioneer.ram: synthesise two fault-free training runs (seeds 1, 2), two test runs
with the thesis's schedule (seeds 3, 4) and one fault-free test run (seed 5), DURATION
seconds each; learn M1-M9 over -Q 0.9 0.8 0.5 x --alpha 10 2.5 0.5 and evaluate them with
``racc evaluate --markdown``; draw one test run's timeline with the hand-written model
(``racc replay --plot``).  The tables replace the part of docs/evaluation.md between its
``generated`` markers, the plot is docs/evaluation-timeline.png.

    .venv/bin/python bench/evaluation.py                # 600 s runs, as in the docs
    .venv/bin/python bench/evaluation.py --duration 300 --keep /tmp/pioneer-eval
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
DOC = ROOT / "docs" / "evaluation.md"
PLOT = ROOT / "docs" / "evaluation-timeline.png"
BEGIN, END = "<!-- generated:begin -->", "<!-- generated:end -->"
RUNS = {
    "train1": ["--seed", "1"],
    "train2": ["--seed", "2"],
    "test1": ["--seed", "3", "--schedule", "thesis"],
    "test2": ["--seed", "4", "--schedule", "thesis"],
    "clean": ["--seed", "5"],
}


def racc(*args: str) -> tuple[float, str]:
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "rac", *args], capture_output=True, text=True, check=False
    )
    if done.returncode != 0:
        sys.exit(f"racc {' '.join(args)} failed ({done.returncode}):\n{done.stderr}")
    return time.perf_counter() - started, done.stdout


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=600.0, help="seconds per run")
    parser.add_argument("--keep", metavar="DIR", help="write the runs here and keep them")
    parser.add_argument("--no-docs", action="store_true", help="print, do not touch docs/")
    args = parser.parse_args()
    scratch = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="racc-eval-"))
    scratch.mkdir(parents=True, exist_ok=True)
    try:
        bags = {}
        for name, extra in RUNS.items():
            bag = scratch / f"{name}.bag"
            bags[name] = str(bag)
            d = f"{args.duration:g}"
            racc("synth", str(PIONEER), "-o", str(bag), "--duration", d, "-q", "--force", *extra)
        elapsed, tables = racc(
            "evaluate", "--learn-from", bags["train1"], bags["train2"], "--base", str(PIONEER),
            "-Q", "0.9", "0.8", "0.5", "--alpha", "10", "2.5", "0.5",
            "--runs", bags["test1"], bags["test2"], bags["clean"], "--markdown",
            "--save-models", str(scratch / "models"),
        )  # fmt: skip
        plot = str(scratch / "timeline.png") if args.no_docs else str(PLOT)
        _, replayed = racc("replay", str(PIONEER), bags["test1"], "--plot", plot)
        learned = sorted((scratch / "models").glob("M*.ram"))
        relations = {p.stem: [ln for ln in p.read_text().splitlines() if ln.startswith("relate")]
                     for p in learned}  # fmt: skip
        # The scratch directory means nothing to a reader of the docs.
        tables, replayed = (x.replace(f"{scratch}/", "") for x in (tables, replayed))
        section = _section(args.duration, elapsed, tables, replayed, relations)
        if args.no_docs:
            print(section)
        else:
            text = DOC.read_text(encoding="utf-8")
            head, rest = text.split(BEGIN, 1)
            _, tail = rest.split(END, 1)
            DOC.write_text(f"{head}{BEGIN}\n{section}\n{END}{tail}", encoding="utf-8")
            print(f"wrote {DOC} and {PLOT} ({elapsed:.0f} s for racc evaluate)")
    finally:
        if not args.keep:
            shutil.rmtree(scratch, ignore_errors=True)


def _section(
    duration: float, elapsed: float, tables: str, replayed: str, relations: dict[str, list[str]]
) -> str:
    m8 = "\n".join(relations.get("M8", [])) or "(none)"
    return "\n".join(
        [
            f"Runs of {duration:g} s each; `racc evaluate` took {elapsed:.0f} s wall on the "
            "2-core machine of the run.",
            "",
            tables.replace("### ", "#### ").rstrip(),
            "",
            "#### What M8 relates",
            "",
            "```ram",
            m8,
            "```",
            "",
            "#### One test run replayed with the hand-written model",
            "",
            "```",
            replayed.rstrip(),
            "```",
            "",
            "![Timeline of test run 1: observations, diagnoses, fault windows]"
            "(evaluation-timeline.png)",
        ]
    )


if __name__ == "__main__":
    main()
