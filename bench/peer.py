"""racc's diagnosis side by side with a python-sat peer on the same model (issue 14).

Run:  .venv/bin/python bench/peer.py [--repeat N] [--sizes 1000 10000]
The peer needs python-sat (``.venv/bin/pip install python-sat``; a bench comparison only,
never a racc dependency); without it the peer columns say so and racc's figures still print.

The models are bench/compile.py's synthetic robots (10,000 nodes: 43,673 clauses, 11,327
components), compiled to model.yaml; the observations are what the observers would report
with two components faulty (``predict``), written one literal per line.  Printed, as
best (median) of N runs:

1. whole process: ``racc diagnose model.yaml --obs-file F --json`` against
   ``bench/sat_peer.py`` (PyYAML's C loader, CNF, RC2 enumerating every minimal diagnosis);
   and ``--obs`` given once per literal (about 40,000 times) against the same run;
2. one consistency check with the model loaded: Θ already encoded (``consistent_ids``)
   against one incremental SAT call (Glucose 4 with the clauses loaded, Θ and NAB(COMPS)
   as assumptions); Θ as literal objects (``is_consistent``: conversion plus propagation)
   against the peer converting the same literals to its variables and calling the solver;
   the index build, repeated in one process and once in a fresh one (as a command builds
   it), beside a reference (a dict keyed by as many atoms: what Python itself takes); the
   10k/1k ratio of each, and each size's working set (the theory and its index, traced)
   against the machine's last-level cache;
3. all minimal diagnoses up to cardinality 2 in process against RC2 (in process, its
   formula built beforehand), and the size of ``--json``'s output.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import cast

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from compile import synthetic_model  # noqa: E402  (bench/compile.py)
from machine import fits_note, last_level_cache, working_set  # noqa: E402  (bench/machine.py)

from rac.diagnosis import compile_theory, diagnose, is_consistent, predict  # noqa: E402
from rac.diagnosis.engine import Index  # noqa: E402
from rac.diagnosis.theory import Theory  # noqa: E402
from rac.load.theory import load_theory  # noqa: E402
from rac.perf import paused_gc  # noqa: E402
from rac.pipeline import compile_model  # noqa: E402
from rac.targets import EmitOptions  # noqa: E402
from rac.targets.model_yaml import emit_model_yaml  # noqa: E402

try:
    from pysat.examples.rc2 import RC2
    from pysat.formula import WCNF
    from pysat.solvers import Solver

    HAVE_PYSAT = True
except ImportError:
    HAVE_PYSAT = False
    NO_PEER = "python-sat missing: pip install python-sat"

Timing = tuple[float, float]  # best, median (seconds)


def timed(action: Callable[[], object], repeat: int) -> Timing:
    """Best and median of ``repeat`` runs.  What the action returns is released after the
    clock stops: freeing a 10k index is its teardown, not its build (a whole process pays
    it, and the whole-process figures include it)."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = action()
        times.append(time.perf_counter() - start)
        del result
    return _best_of(times)


def process(command: list[str], repeat: int) -> tuple[Timing, int]:
    """Wall time of a fresh process, and the size of what it prints."""
    size = 0

    def once() -> None:
        nonlocal size
        done = subprocess.run(command, check=True, capture_output=True)
        size = len(done.stdout)

    return timed(once, repeat), size


def literal_lines(theory: Theory, faults: list[str]) -> list[str]:
    return [str(o.atom) if o.positive else f"not {o.atom}" for o in predict(theory, faults)]


class SatPeer:
    """The model as CNF once (as the peer script builds it), for in-process figures."""

    def __init__(self, theory: Theory) -> None:
        self.ids: dict[tuple[str, tuple[str, ...]], int] = {}
        self.hard: list[list[int]] = []
        for clause in theory.clauses:
            body = [-self.var(a.predicate, a.args) for a in clause.body]
            head = clause.head
            self.hard.append(body if head.predicate == "false" else [*body, self.var(*_k(head))])
        for (pred, args), v in list(self.ids.items()):
            if pred.startswith(theory.neg_prefix):
                other = self.ids.get((pred.removeprefix(theory.neg_prefix), args))
                if other:
                    self.hard.append([-v, -other])
        self.nab = {c: self.var(theory.nab, (c,)) for c in theory.components}
        self.ab = {c: self.var(theory.ab, (c,)) for c in theory.components}
        for c in theory.components:
            self.hard += [[self.ab[c], self.nab[c]], [-self.ab[c], -self.nab[c]]]
        self.neg = theory.neg_prefix

    def var(self, pred: str, args: tuple[str, ...]) -> int:
        key = (pred, args)
        found = self.ids.get(key)
        if found is None:
            found = self.ids[key] = len(self.ids) + 1
        return found

    def units(self, observations: tuple[object, ...]) -> list[int]:
        out = []
        for lit in observations:
            atom = lit.atom  # type: ignore[attr-defined]
            v = self.var(atom.predicate, atom.args)
            out.append(v if lit.positive else -v)  # type: ignore[attr-defined]
        return out

    def rc2_diagnoses(self, units: list[int], max_card: int) -> list[list[str]]:
        wcnf = WCNF()
        for clause in self.hard:
            wcnf.append(clause)
        for u in units:
            wcnf.append([u])
        for v in self.nab.values():
            wcnf.append([v], weight=1)
        found: list[list[str]] = []
        with RC2(wcnf, solver="g4") as rc2:
            while (model := rc2.compute()) is not None and rc2.cost <= max_card:
                true = {v for v in model if v > 0}
                bad = sorted(c for c, v in self.nab.items() if v not in true)
                found.append(bad)
                if not bad:
                    break
                rc2.add_clause([self.nab[c] for c in bad])
        return found


def _k(atom: object) -> tuple[str, tuple[str, ...]]:
    return atom.predicate, atom.args  # type: ignore[attr-defined]


def measure(size: int, repeat: int, work: Path) -> dict[str, object]:
    compiled = compile_model(synthetic_model(size))
    directory = work / f"synthetic{size}"
    directory.mkdir()
    model_yaml = directory / "model.yaml"
    model_yaml.write_text(emit_model_yaml(compiled, EmitOptions()), encoding="utf-8")
    theory = load_theory(str(model_yaml))
    comps = theory.components
    faults = [comps[len(comps) // 3], comps[2 * len(comps) // 3]]
    lines = literal_lines(theory, faults)
    obs_file = directory / "obs.txt"
    obs_file.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(
        f"{size} nodes: {len(theory.clauses)} clauses, {len(comps)} components, "
        f"{len(lines)} observations, faults {faults}",
        flush=True,
    )
    racc = [sys.executable, "-m", "rac", "diagnose", str(model_yaml)]
    out: dict[str, object] = {}
    out["racc diagnose --obs-file --json"] = process(
        [*racc, "--obs-file", str(obs_file), "--json"], repeat
    )
    obs_args = [x for line in lines for x in ("--obs", line)]
    # the kernel's limit on a command line (environment included): beyond 10k nodes, the
    # observations no longer fit as arguments
    if sum(len(x) + 9 for x in obs_args) + 65536 < os.sysconf("SC_ARG_MAX"):
        out["racc diagnose --obs x N --json"] = process([*racc, *obs_args, "--json"], repeat)
    else:
        print(f"  ({len(lines)} --obs arguments exceed the command-line limit: not run)")
    out["racc --json --with-good"] = process(
        [*racc, "--obs-file", str(obs_file), "--json", "--with-good"], 1
    )
    peer_script = [sys.executable, str(ROOT / "bench" / "sat_peer.py"), str(model_yaml)]
    if HAVE_PYSAT:
        out["peer whole process"] = process([*peer_script, str(obs_file)], repeat)
    theta = predict(theory, faults)
    out["index build"] = timed(lambda: Index(theory), repeat)
    fresh = [sys.executable, __file__, "--index-build", str(model_yaml)]
    out["index build, fresh process"] = _best_of([_run_float(fresh) for _ in range(repeat)])
    # what the build reads and writes: the theory and the index (the index keeps the theory)
    out["working set"] = working_set(lambda: Index(load_theory(str(model_yaml))))
    keys = _atom_keys(theory)
    out["reference: a dict of as many atoms"] = timed(lambda: _dict_reference(keys), repeat)
    index = compile_theory(theory)
    index.normal()  # once per model, as the first check builds it
    theta_ids = np.asarray(index.observed_ids(theta))  # Θ encoded once, as the peer's units
    out["consistency check, Θ as ids"] = timed(lambda: index.consistent_ids(theta_ids), repeat * 4)
    out["is_consistent(Θ literals)"] = timed(lambda: is_consistent(theory, theta), repeat * 4)
    out["diagnoses <= 2"] = timed(lambda: diagnose(theory, theta, 2), repeat)
    if HAVE_PYSAT:
        peer = SatPeer(theory)
        units = peer.units(theta)
        assumptions = units + list(peer.nab.values())
        with Solver(name="g4", bootstrap_with=peer.hard) as solver:
            solver.solve(assumptions=assumptions)  # warm: the solver's state is loaded
            out["peer consistency check"] = timed(
                lambda: solver.solve(assumptions=assumptions), repeat * 4
            )
            nab = list(peer.nab.values())
            out["peer check, Θ literals converted"] = timed(
                lambda: solver.solve(assumptions=peer.units(theta) + nab), repeat * 4
            )
        out["peer diagnoses <= 2 (RC2)"] = timed(lambda: peer.rc2_diagnoses(units, 2), repeat)
        ours = [list(d) for d in diagnose(theory, theta, 2).diagnoses]
        assert peer.rc2_diagnoses(units, 2) == ours, "the peer and racc disagree"
    return out


def _run_float(command: list[str]) -> float:
    return float(subprocess.run(command, check=True, capture_output=True, text=True).stdout)


def _best_of(times: list[float]) -> Timing:
    return min(times), statistics.median(times)


def index_build_once(model_yaml: str) -> float:
    """The index build as ``racc diagnose`` pays it: once, in a fresh process, right after
    the model is read (with the 1k model in the cache and the 10k one mostly not, where a
    build repeated in one process finds either warm)."""
    theory = load_theory(model_yaml)
    start = time.perf_counter()
    Index(theory)
    return time.perf_counter() - start


def _atom_keys(theory: Theory) -> list[tuple[str, tuple[str, ...]]]:
    """Every atom of the theory and its negation, as the index keys them."""
    keys = [(a.predicate, a.args) for c in theory.clauses for a in (c.head, *c.body)]
    keys = list(dict.fromkeys(keys))
    return keys + [(theory.neg_prefix + p, a) for p, a in keys]


def _dict_reference(keys: list[tuple[str, tuple[str, ...]]]) -> object:
    """Key a dict by every atom, look each one up once, give each an empty list: Python's
    own floor for an index of that size.  Its 10k/1k ratio shows how far this machine's
    memory hierarchy alone bends work that is linear.  The collector is paused, as it is
    for the index build."""
    with paused_gc():
        ids = dict(zip(keys, range(len(keys)), strict=True))
        found = [ids[k] for k in keys]
        lists = [[] for _ in keys]
    return ids, found, lists


def show(name: str, value: object) -> str:
    if isinstance(value, tuple) and isinstance(value[0], tuple):
        (best, median), size = value
        return f"{name:<36} {best * 1000:>9.1f} ms ({median * 1000:>8.1f}), {size:,} B out"
    best, median = value  # type: ignore[misc]
    return f"{name:<36} {best * 1000:>9.2f} ms ({median * 1000:>8.2f})"


def ratio(a: object, b: object) -> float:
    def best(v: object) -> float:
        return v[0][0] if isinstance(v[0], tuple) else v[0]  # type: ignore[index,return-value]

    return best(a) / best(b)


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per figure (default 5)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--index-build", metavar="MODEL_YAML", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.index_build:  # one measurement in this fresh process (index_build_once)
        print(index_build_once(args.index_build))
        return 0
    if not HAVE_PYSAT:
        print(f"note: {NO_PEER}; printing racc's figures only")
    with tempfile.TemporaryDirectory() as tmp:
        results = {size: measure(size, args.repeat, Path(tmp)) for size in args.sizes}
    print(f"\nbest (median) of {args.repeat}; load average {os.getloadavg()[0]:.1f}")
    for size, figures in results.items():
        print(f"-- {size} nodes")
        for name, value in figures.items():
            if name != "working set":
                print("  " + show(name, value))
        if HAVE_PYSAT:
            pairs = (
                ("racc diagnose --obs-file --json", "peer whole process"),
                ("racc diagnose --obs x N --json", "peer whole process"),
                ("consistency check, Θ as ids", "peer consistency check"),
                ("is_consistent(Θ literals)", "peer consistency check"),
                ("is_consistent(Θ literals)", "peer check, Θ literals converted"),
                ("diagnoses <= 2", "peer diagnoses <= 2 (RC2)"),
            )
            for ours, theirs in pairs:
                if ours not in figures:
                    continue
                shown = f"{ours} / {theirs}"
                print(f"  racc/peer {shown:<66} {ratio(figures[ours], figures[theirs]):6.2f}")
    if len(results) == 2:
        low, high = sorted(results)
        small, large = results[low], results[high]
        label = f"{high // 1000}k/{low // 1000}k" if low % 1000 == 0 else f"{high}/{low}"
        names = (
            "index build",
            "index build, fresh process",
            "reference: a dict of as many atoms",
            "consistency check, Θ as ids",
            "is_consistent(Θ literals)",
        )
        for name in (*names, "diagnoses <= 2"):
            print(f"{label} {name:<30} {ratio(large[name], small[name]):6.1f}")
    sets = {size: cast(int, figures["working set"]) for size, figures in results.items()}
    print(f"index build: {fits_note(sets, last_level_cache())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
