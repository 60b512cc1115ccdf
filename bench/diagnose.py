"""Benchmark of the diagnosis engine on synthetic robots of 1,000 and 10,000 components.

Run:  .venv/bin/python bench/diagnose.py [--repeat N]

A synthetic robot has groups of four components: a switchable device hw_i, its driver drv_i
(publishing the regular topic /raw_i), a filter proc_i (fusing /raw_i with the output of an
earlier filter into /out_i) and a consumer use_i; every node declares cpu/mem limits and every
tenth group relates /raw_i.x to /out_i.x.  The observations are what the observers would
report (``predict``): all observable atoms, with the injected components abnormal.

Printed per size: index build, one consistency check (clauses ∪ Θ ∪ NAB(COMPS), one linear
propagation), a single-fault diagnosis (all minimal diagnoses) and all minimal diagnoses up to
cardinality 2 with two independent faults, and (beyond the issue) all minimal diagnoses of a
single symptom with nothing else observed, where every component upstream is a candidate;
then the 10k/1k ratio of each figure.

Then the scaling of two shapes whose answer grows with the model (issue 27), at 1k, 4k and
20k components (``--scaling`` picks the sizes, ``--scaling-only`` skips the figures above):

- a chain ``NAB(c_i), ok(s_{i-1}) -> ok(s_i)`` with ``ok(s0)`` and ``not ok(sN)`` observed:
  one minimal conflict (the whole chain) and n single-fault diagnoses;
- a wide fan-in: n components ``NAB(c_i), ok(in_i) -> ok(t_i)`` feeding one fusion
  ``NAB(f), ok(t_1), ..., ok(t_n) -> ok(out)``, every input ok and ``out`` not: n + 1
  single-fault diagnoses;

each diagnosed in full and up to cardinality 2, with the 20k/1k ratio of each time (linear
is 20): the least CPU time of this process over at least ``--repeat`` runs and ``--seconds``
of runs per figure, the sizes taking turns (see ``best_times``).  The chain took 296 s at
20k (a consistency check per candidate, each as long as the chain).  ``--phases`` also
splits one diagnosis of each shape into its phases (observations to numbers, the closures,
the search, the result) at the first and last size: where the time above linear is.
"""

from __future__ import annotations

import argparse
import functools
import os
import random
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rac.diagnosis import Theory, compile_theory, diagnose, parse_literal, predict
from rac.diagnosis.engine import Index
from rac.interchange import parse_json
from rac.pipeline import compile_model

SIZES = (1_000, 10_000)


def synthetic_ram(components: int, seed: int = 7) -> dict[str, Any]:
    """A ram/1 document with ``components`` components (a multiple of four)."""
    rng = random.Random(seed)
    groups = components // 4
    hardware, topics, nodes, related = [], [], [], []
    limits = {"cpu": 10.0, "mem": 64_000_000}
    for i in range(groups):
        hardware.append({"name": f"hw_{i}", "switchable": True, "channel": i + 1})
        topics.append({"name": f"/raw_{i}", "fields": ["x"], "rate_hz": 10.0})
        topics.append({"name": f"/out_{i}", "fields": ["x"], "rate_hz": 10.0})
        topics.append({"name": f"/cmd_{i}", "fields": ["x"]})
        nodes.append(
            {
                "name": f"drv_{i}",
                "drives": [f"hw_{i}"],
                "limits": limits,
                "publishes": [{"topic": f"/raw_{i}"}],
            }
        )
        inputs = [f"/raw_{i}"] + ([f"/out_{rng.randrange(i)}"] if i else [])
        nodes.append(
            {
                "name": f"proc_{i}",
                "subscribes": inputs,
                "limits": limits,
                "publishes": [{"topic": f"/out_{i}", "affected_by": inputs}],
            }
        )
        nodes.append(
            {
                "name": f"use_{i}",
                "subscribes": [f"/out_{i}"],
                "limits": limits,
                "publishes": [{"topic": f"/cmd_{i}", "affected_by": [f"/out_{i}"]}],
            }
        )
        if i % 10 == 0:
            related.append([f"/raw_{i}.x", f"/out_{i}.x"])
    return {
        "format": "ram/1",
        "name": "synthetic",
        "hardware": hardware,
        "topics": topics,
        "nodes": nodes,
        "related": related,
    }


def synthetic_theory(components: int) -> Theory:
    import json

    compiled = compile_model(parse_json(json.dumps(synthetic_ram(components)), "synthetic.json"))
    return Theory(compiled.rbm, compiled.props, compiled.components, model=compiled.model)


Timing = tuple[float, float]  # (best, median) in ms


def timed(
    action: Callable[[], object], repeat: int, clock: Callable[[], float] = time.perf_counter
) -> Timing:
    """Best and median of ``repeat`` runs; the best is the figure least disturbed by load.
    What the action returns is released after the clock stops (freeing a 10k index is its
    teardown, not its build)."""
    times = []
    for _ in range(repeat):
        start = clock()
        result = action()
        times.append((clock() - start) * 1000)
        del result
    return min(times), statistics.median(times)


def measure(components: int, repeat: int) -> dict[str, Timing]:
    theory = synthetic_theory(components)
    groups = components // 4
    Index(theory)  # once first: the numpy import is the process's, not the build's
    build = timed(lambda: Index(theory), repeat)
    index = compile_theory(theory)
    one = predict(theory, [f"proc_{groups // 2}"])
    two = predict(theory, [f"proc_{groups // 3}", f"hw_{2 * groups // 3}"])

    def check() -> bool:
        base, clash = index.base(one)
        return bool(clash) or bool(index.run(base, index.all_nab).clash)

    symptom = (parse_literal(f"not ok(out_{groups - 1})", theory),)
    single = diagnose(theory, one)
    double = diagnose(theory, two, max_card=2)
    assert single.diagnoses == ((f"proc_{groups // 2}",),), single.diagnoses
    assert (f"hw_{2 * groups // 3}", f"proc_{groups // 3}") in double.diagnoses
    print(
        f"  {components} components: {len(theory.clauses)} clauses, {len(theory.props)} "
        f"observations; double fault: {len(double.diagnoses)} diagnoses; one symptom: "
        f"{len(diagnose(theory, symptom).diagnoses)} diagnoses"
    )
    return {
        "index build (once per model)": build,
        "consistency check": timed(check, repeat),
        "single-fault diagnosis": timed(lambda: diagnose(theory, one), repeat),
        "all diagnoses <= 2, two faults": timed(lambda: diagnose(theory, two, 2), repeat),
        "one symptom only, all diagnoses": timed(lambda: diagnose(theory, symptom), repeat),
    }


def chain_yaml(n: int) -> str:
    """A model.yaml chain of n components (see the module's docstring)."""
    props = "".join(f"  - ok(s{i})\n" for i in range(n + 1))
    rules = "".join(f"  - NAB(c{i}), ok(s{i - 1}) -> ok(s{i})\n" for i in range(1, n + 1))
    return f"ab: AB\nnab: NAB\nneg_prefix: not_\nprops:\n{props}rules:\n{rules}"


def fan_in_yaml(n: int) -> str:
    """A model.yaml of n components fused by one more (see the module's docstring)."""
    props = "".join(f"  - ok(in{i})\n" for i in range(n)) + "  - ok(out)\n"
    rules = "".join(f"  - NAB(c{i}), ok(in{i}) -> ok(t{i})\n" for i in range(n))
    fused = ", ".join(f"ok(t{i})" for i in range(n))
    rules += f"  - NAB(f), {fused} -> ok(out)\n"
    return f"ab: AB\nnab: NAB\nneg_prefix: not_\nprops:\n{props}rules:\n{rules}"


def scaling_case(shape: str, n: int) -> tuple[Theory, list[Any]]:
    from rac.diagnosis import Literal
    from rac.load.model_yaml import parse_model_yaml
    from rac.logic import Atom

    if shape == "chain":
        theory = parse_model_yaml(chain_yaml(n), "chain.yaml")
        observed = [("s0", True), (f"s{n}", False)]
    else:
        theory = parse_model_yaml(fan_in_yaml(n), "fan_in.yaml")
        observed = [*((f"in{i}", True) for i in range(n)), ("out", False)]
    return theory, [Literal(Atom("ok", (s,)), positive) for s, positive in observed]


def best_times(
    actions: Sequence[Callable[[], object]], repeat: int, seconds: float
) -> list[tuple[float, int]]:
    """The least CPU time in ms of each action, and its number of runs: each runs at least
    ``repeat`` times and for at least ``seconds`` in all, in turns of 0.1 s each.

    Every size gets the same time, spread over the same stretch of the clock, to meet a
    quiet moment: with a fixed count run size after size, a 2 ms case had 30 ms to do so
    and a 50 ms one 0.75 s, one of them could fall wholly into a busy spell of the
    neighbours' (seconds long on a shared machine), and the ratio moved from run to run.
    """
    times: list[list[float]] = [[] for _ in actions]
    spent = [0.0] * len(actions)
    while any(len(t) < repeat or s < seconds for t, s in zip(times, spent, strict=True)):
        for k, action in enumerate(actions):
            turn = 0.0
            while turn < min(0.1, seconds) or not times[k]:
                start = time.process_time()  # CPU time: the wait for a core is not the code's
                result = action()
                took = time.process_time() - start
                del result
                times[k].append(took)
                turn += took
            spent[k] += turn
    return [(min(t) * 1000, len(t)) for t in times]


def measure_scaling(sizes: list[int], repeat: int, seconds: float) -> None:
    """Chain and fan-in: diagnosis time per size, and the last size's ratio to the first."""
    rows: dict[str, list[float]] = {}
    for shape in ("chain", "fan-in"):
        cases = [scaling_case(shape, n) for n in sizes]
        for n, (theory, observed) in zip(sizes, cases, strict=True):
            compile_theory(theory)  # the index is built once per model, not per diagnosis
            found = diagnose(theory, observed)
            expected = n if shape == "chain" else n + 1
            assert len(found.diagnoses) == expected, (shape, n, len(found.diagnoses))
            assert all(len(d) == 1 for d in found.diagnoses)
        for card in (None, 2):
            name = f"{shape}, all diagnoses" + (" <= 2" if card else "")
            runs = [functools.partial(diagnose, t, o, card) for t, o in cases]
            for n, (best, count) in zip(sizes, best_times(runs, repeat, seconds), strict=True):
                rows.setdefault(name, []).append(best)
                print(f"  {name:<28} n={n:>6,}: {best:8.2f} ms (best of {count})", flush=True)
    print(
        f"\nCPU time in ms, best of at least {repeat} runs and {seconds:g} s per figure; "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    head = "".join(f"{n:>10,}" for n in sizes)
    print(f"{'shape':<28}{head} {f'{sizes[-1] // 1000}k/{sizes[0] // 1000}k':>9}")
    for name, times in rows.items():
        cells = "".join(f"{t:>10.2f}" for t in times)
        print(f"{name:<28}{cells} {times[-1] / times[0]:>9.1f}")


def diagnosis_phases(theory: Theory, observed: list[Any]) -> dict[str, float]:
    """One diagnosis of Θ, as ``diagnose`` runs it, split into its phases: CPU time of each."""
    from rac.diagnosis.result import _ordered
    from rac.diagnosis.search import HittingSetDag, transversals
    from rac.perf import paused_gc

    clock = time.process_time
    marks = [("", clock())]
    with paused_gc():
        index = compile_theory(theory)
        ids = index.observed_ids(observed)
        marks.append(("observations to numbers", clock()))
        base, _ = index.base_ids(ids)
        marks.append(("closure of Θ (base)", clock()))
        full = index.full(base)
        marks.append(("all-normal closure", clock()))
        search = HittingSetDag(index, base, full, strong=True).run(None)
        marks.append(("hitting-set search", clock()))
        conflicts = transversals(search.larger, search.singles)
        ordered = (_ordered(conflicts, index), _ordered(search.larger, index, search.singles))
        marks.append(("conflicts and result", clock()))
    marks.append(("collector resumed", clock()))
    del ordered
    return {name: (t - marks[k][1]) * 1000 for k, (name, t) in enumerate(marks[1:])}


def measure_phases(sizes: list[int], repeat: int) -> None:
    """The phases of the chain's and the fan-in's diagnosis at the first and last size, each
    the least over ``repeat`` turns of 0.1 s, and their ratio."""
    small, large = sizes[0], sizes[-1]
    for shape in ("chain", "fan-in"):
        cases = {n: scaling_case(shape, n) for n in (small, large)}
        runs: dict[int, list[dict[str, float]]] = {small: [], large: []}
        for turn in range(repeat + 1):  # in turns of 0.1 s, as the totals; the first warms up
            for n, (theory, observed) in cases.items():
                spent = 0.0
                while spent < 0.1:
                    phases = diagnosis_phases(theory, observed)
                    spent += sum(phases.values()) / 1000
                    if turn:
                        runs[n].append(phases)
        best = {n: {name: min(run[name] for run in runs[n]) for name in runs[n][0]} for n in runs}
        print(f"\n{shape}: phases of one diagnosis, CPU ms, least over {repeat} turns of 0.1 s")
        print(f"{'phase':<26}{small:>10,}{large:>10,}{'ratio':>8}")
        for name, t_small in best[small].items():
            t_large = best[large][name]
            ratio = f"{t_large / t_small:8.1f}" if t_small > 0.005 else f"{'-':>8}"
            print(f"{name:<26}{t_small:10.3f}{t_large:10.3f}{ratio}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per figure (median)")
    parser.add_argument(
        "--scaling",
        type=int,
        nargs="+",
        default=[1000, 4000, 20000],
        help="chain and fan-in sizes (default 1000 4000 20000)",
    )
    parser.add_argument(
        "--scaling-only", action="store_true", help="only the chain and fan-in scaling"
    )
    parser.add_argument(
        "--phases",
        action="store_true",
        help="also the phases of one chain and fan-in diagnosis at the first and last size",
    )
    parser.add_argument(
        "--seconds",
        type=float,
        default=2.0,
        help="least CPU time of runs per chain and fan-in figure (default 2.0)",
    )
    args = parser.parse_args()
    if not args.scaling_only:
        _synthetic_figures(args.repeat)
    print("\nchain and fan-in scaling:")
    measure_scaling(args.scaling, args.repeat, args.seconds)
    if args.phases:
        measure_phases(args.scaling, max(args.repeat, 20))


def _synthetic_figures(repeat: int) -> None:
    args = argparse.Namespace(repeat=repeat)
    results = {size: measure(size, args.repeat) for size in SIZES}
    small, large = results[SIZES[0]], results[SIZES[1]]
    print(f"\nbest (median) of {args.repeat} runs, in ms; load average {os.getloadavg()[0]:.1f}")
    print(f"{'figure':<32} {'1k':>17} {'10k':>19} {'10k/1k':>7}")
    for name in small:
        (b1, m1), (b10, m10) = small[name], large[name]
        print(f"{name:<32} {b1:>8.2f} ({m1:>6.2f}) {b10:>9.2f} ({m10:>7.2f}) {b10 / b1:>7.1f}")


if __name__ == "__main__":
    main()
