"""Fuzz racc with hostile inputs: N mutants of each input kind, each with a time-out.

    python bench/fuzz.py --cases 100000 [--timeout 10] [--jobs 2] [--minutes 10]

Cases are split evenly over the kinds (.ram, ram/1 JSON, model.yaml, --obs literals, damaged
rosbag2 recordings in sqlite3 and MCAP through learn and replay, YAML nested up to 5,000 deep
in every YAML file a command reads); each runs in a worker process (forked once per batch and
again after a hang), which compiles or diagnoses it in-process and checks that every output of
an accepted model parses back (YAML, launch files with an XML parser, PDDL with ``pddl``,
model.yaml with ``racc diagnose``).
A case still running after the time-out is a hang: its worker is killed.  Prints, per kind,
the counts accepted / clean error / crash / hang, and each crash or hang's seed
(reproduce with ``tests/fuzz_cases.py``'s ``make_case(kind, seed)``).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import shutil
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from multiprocessing.connection import Connection
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from fuzz_cases import KINDS, make_case, remove_base_bags, run_case


def _worker(conn: Connection, jobs: list[tuple[str, int]]) -> None:
    with tempfile.TemporaryDirectory(prefix="racc-fuzz-") as tmp:
        for index, (kind, seed) in enumerate(jobs):
            workdir = Path(tmp) / str(index)
            workdir.mkdir()
            conn.send(("start", index))
            outcome, detail = run_case(make_case(kind, seed), workdir)
            conn.send(("done", index, outcome, detail))
            shutil.rmtree(workdir, ignore_errors=True)
    conn.send(("end",))


def _run_share(
    jobs: list[tuple[str, int]], timeout: float, deadline: float
) -> list[tuple[str, int, str, str]]:
    """Run ``jobs`` in a chain of workers, restarting after a hang; stop at ``deadline``."""
    results: list[tuple[str, int, str, str]] = []
    ctx = mp.get_context("fork")
    start = 0
    while start < len(jobs) and time.monotonic() < deadline:
        parent, child = ctx.Pipe()
        proc = ctx.Process(target=_worker, args=(child, jobs[start:]), daemon=True)
        proc.start()
        child.close()
        current = None
        finished = 0  # cases this worker has answered
        while True:
            if not parent.poll(timeout):
                if current is None:  # between cases (starting up, cleaning up): not a hang
                    continue
                kind, seed = jobs[start + current]
                results.append((kind, seed, "hang", f"no answer in {timeout:g} s"))
                proc.kill()
                start += current + 1
                break
            try:
                message = parent.recv()
            except EOFError:  # the worker died (a segfault, os._exit): a crash
                if current is None:  # died between cases: go on after the last answered one
                    start += finished
                    break
                kind, seed = jobs[start + current]
                results.append((kind, seed, "crash", "the worker died"))
                start += current + 1
                break
            if message[0] == "start":
                current = message[1]
            elif message[0] == "done":
                current = None
                finished = message[1] + 1
                kind, seed = jobs[start + message[1]]
                results.append((kind, seed, message[2], message[3]))
                if time.monotonic() > deadline:
                    proc.kill()
                    start = len(jobs)
                    break
            else:
                start = len(jobs)
                break
        proc.join(1)
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", type=int, default=1000, help="cases in all (default 1000)")
    parser.add_argument("--timeout", type=float, default=10.0, help="seconds a case may take")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--minutes", type=float, default=0, help="stop after this long (0: never)")
    parser.add_argument("--kinds", default=",".join(KINDS), help="comma-separated input kinds")
    parser.add_argument("--seed", type=int, default=0, help="first seed")
    args = parser.parse_args()
    kinds = args.kinds.split(",")
    per_kind = max(1, args.cases // len(kinds))
    # Interleave the kinds so that a time-boxed run still covers each of them.
    jobs = [(k, args.seed + i) for i in range(per_kind) for k in kinds]
    shares = [jobs[j :: args.jobs] for j in range(args.jobs)]
    deadline = time.monotonic() + (args.minutes * 60 if args.minutes else float("inf"))
    began = time.monotonic()
    for kind in kinds:  # the seed texts and base recordings, made once before the forks
        make_case(kind, args.seed)
    # One supervising thread per share; each forks its own chain of worker processes.
    try:
        with ThreadPoolExecutor(args.jobs) as pool:
            parts = list(pool.map(lambda s: _run_share(s, args.timeout, deadline), shares))
    finally:
        remove_base_bags()
    results = [r for part in parts for r in part]
    elapsed = time.monotonic() - began
    counts: dict[str, Counter[str]] = {k: Counter() for k in kinds}
    for kind, _, outcome, _ in results:
        counts[kind][outcome] += 1
    print(f"{len(results)} cases in {elapsed:.0f} s, time-out {args.timeout:g} s per case")
    print(f"{'kind':<8} {'cases':>7} {'accepted':>9} {'error':>7} {'crash':>6} {'hang':>5}")
    for kind in kinds:
        c = counts[kind]
        total = sum(c.values())
        row = f"{c['accepted']:>9} {c['error']:>7} {c['crash']:>6} {c['hang']:>5}"
        print(f"{kind:<8} {total:>7} {row}")
    bad = [r for r in results if r[2] in ("crash", "hang")]
    for kind, seed, outcome, detail in bad[:50]:
        print(f"{outcome}: make_case({kind!r}, {seed}): {detail.strip()[-400:]}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
