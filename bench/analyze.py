"""Analysis and placement benchmark: a random 300-node robot with feedback loops.

Run with ``.venv/bin/python bench/analyze.py`` (``--nodes N``, ``--mode output|crash|…``,
``--loops K``).  The model is ``bench/compile.py``'s synthetic robot with K feedback edges
added (a node reads a topic published downstream of it and makes an output depend on it), so
the loop rule is exercised too.  Timed: compiling it, ``analyze`` in the mode, and ``place``
(candidates, requirements, the clarabel LP, rounding and the check of the patched model).
The issue's bar is analysis plus placement under 10 s; the figures are printed, not asserted.
"""

from __future__ import annotations

import argparse
import dataclasses
import random
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from compile import synthetic_model

from rac.analysis.analyze import analyze
from rac.analysis.place import place
from rac.diagnosis.theory import Theory
from rac.ir import Model, Name, Publication
from rac.passes.loops import find_loops
from rac.pipeline import compile_model


def with_loops(model: Model, loops: int, seed: int = 7) -> Model:
    """Add ``loops`` feedback edges: node i reads a topic of a later node j that reads i."""
    rng = random.Random(seed)
    nodes = list(model.nodes)
    readers: dict[str, list[int]] = {}
    for k, node in enumerate(nodes):
        for t in node.subscribes:
            readers.setdefault(t.value, []).append(k)
    added = 0
    for _ in range(loops * 50):
        if added == loops:
            break
        i = rng.randrange(len(nodes))
        src = nodes[i]
        if not src.publishes:
            continue
        downstream = [k for t in src.published_topics for k in readers.get(t, ()) if k > i]
        if not downstream:
            continue
        j = rng.choice(downstream)
        back = nodes[j].published_topics[0]
        if back in {t.value for t in src.subscribes}:
            continue
        first = src.publishes[0]
        pub = Publication(first.topic, (*first.affected_by, Name(back)))
        nodes[i] = dataclasses.replace(
            src,
            subscribes=(*src.subscribes, Name(back)),
            publishes=(pub, *src.publishes[1:]),
        )
        added += 1
    return dataclasses.replace(model, nodes=tuple(nodes))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=300)
    parser.add_argument("--loops", type=int, default=8)
    parser.add_argument("--mode", default="output")
    args = parser.parse_args()

    model = with_loops(synthetic_model(args.nodes), args.loops)
    t0 = time.perf_counter()
    compiled = compile_model(model)
    theory = Theory(compiled.rbm, compiled.props, compiled.components, model=compiled.model)
    t1 = time.perf_counter()
    result = analyze(theory, args.mode)
    t2 = time.perf_counter()
    placement = place(theory, args.mode, before=result)
    t3 = time.perf_counter()
    loops = find_loops(compiled.model)
    after = placement.after
    print(
        f"model: {len(model.nodes)} nodes, {len(model.topics)} topics, "
        f"{len(compiled.components)} components, {len(compiled.rbm)} clauses, "
        f"{len(loops)} feedback loops ({sum(len(lp.topics) for lp in loops)} topics on loops)"
    )
    print(
        f"analysis ({args.mode}): {len(result.faults)} faults, detectable "
        f"{result.detectable_pct:.1f} %, isolable {result.isolable_pct:.1f} %, mean group "
        f"{result.mean_group:.2f}, {len(result.groups)} ambiguity groups"
    )
    ratio = placement.cost / placement.lp_bound if placement.lp_bound > 1e-9 else 1.0
    print(
        f"placement: {len(placement.candidates)} candidates, {len(placement.requirements)} "
        f"requirements ({len(placement.unresolvable)} no candidate meets), chosen "
        f"{len(placement.chosen)}, cost {placement.cost:g}, LP bound {placement.lp_bound:.3f} "
        f"(ratio {ratio:.3f}); after: detectable {after.detectable_pct:.1f} %, isolable "
        f"{after.isolable_pct:.1f} %"
    )
    print(
        f"time: compile {t1 - t0:.2f} s, analyze {t2 - t1:.2f} s, place {t3 - t2:.2f} s, "
        f"analyze + place {t3 - t1:.2f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
