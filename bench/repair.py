"""Repair benchmark: the power-up scenario (§10.1.1.1) of synthetic robots.

Run with ``.venv/bin/python bench/repair.py`` (``--sizes 10 100 1000`` picks the component
counts, ``--timeout S`` the planner's limit, ``--diagnose`` also times the diagnosis).

A robot of N components has N/4 switchable devices, each driven by its own driver node, and
N/2 software nodes in a pipeline fed by the drivers' topics: the same shape as TEDUSAR's.
Power-up: every device off, every node stopped, all of them diagnosed faulty (the one minimal
diagnosis).  Timed: problem generation (makePlanningProblem and the PDDL text), the planner
(Fast Downward with its translator: wall clock, and the CPU time of its processes, which a
loaded machine does not inflate), the check of the plan against the domain's semantics;
printed with the plan length, never asserted.  The issue's bar: a 1,000-component power-up
planned in under 10 s.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rac.diagnosis import Theory, diagnose
from rac.ir import Hardware, Model, Name, Node, Publication, Topic
from rac.pipeline import compile_model
from rac.repair import (
    check_plan,
    make_problem,
    render_problem,
    repair_system,
    run_planner,
)
from rac.repair.scenario import observations, power_up
from rac.targets.pddl_domain import render_repair_domain


def synthetic_robot(components: int) -> Model:
    """About ``components`` components: devices, their drivers, and a software pipeline."""
    devices = max(1, components // 4)
    software = max(1, components - 2 * devices)
    hardware = tuple(Hardware(Name(f"dev{i}"), True, i + 1) for i in range(devices))
    nodes = [
        Node(
            Name(f"driver{i}"),
            drives=(Name(f"dev{i}"),),
            publishes=(Publication(Name(f"/raw{i}")),),
        )
        for i in range(devices)
    ]
    for j in range(software):
        source = f"/raw{j % devices}" if j < devices else f"/out{j - devices}"
        nodes.append(
            Node(
                Name(f"proc{j}"),
                subscribes=(Name(source),),
                publishes=(Publication(Name(f"/out{j}"), (Name(source),)),),
            )
        )
    topics = tuple(
        Topic(Name(t), "std_msgs/Float64", rate_hz=10.0)
        for t in [*(f"/raw{i}" for i in range(devices)), *(f"/out{j}" for j in range(software))]
    )
    return Model(
        Name(f"synthetic{components}"), hardware=hardware, topics=topics, nodes=tuple(nodes)
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--timeout", type=float, default=60.0, help="planner limit (s)")
    parser.add_argument("--diagnose", action="store_true", help="also time the diagnosis")
    args = parser.parse_args()
    print(
        f"{'comps':>6} {'problem gen':>12} {'planner wall':>13} {'planner cpu':>12} "
        f"{'check':>8} {'plan':>5}  diagnosis"
    )
    for size in args.sizes:
        compiled = compile_model(synthetic_robot(size))
        theory = Theory(compiled.rbm, compiled.props, compiled.components, model=compiled.model)
        system = repair_system(theory)
        scenario = power_up(system)
        theta = observations(theory, scenario.faulty)
        note = "skipped (--diagnose)"
        if args.diagnose:
            start = time.perf_counter()
            result = diagnose(theory, theta)
            note = f"{time.perf_counter() - start:.2f} s, {len(result.diagnoses)} minimal"
        start = time.perf_counter()
        problem = make_problem(compiled.model.name.value, system, theta, scenario.faulty)
        text = render_problem(problem)
        domain = render_repair_domain(compiled.model.name.value)
        gen = time.perf_counter() - start
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        run = run_planner(domain, text, args.timeout)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        names = problem.component_of()
        plan = tuple((s[0], *(names[a] for a in s[1:])) for s in run.plan)
        start = time.perf_counter()
        check_plan(problem, plan)
        check = time.perf_counter() - start
        print(
            f"{len(system.components):>6} {gen * 1000:>9.1f} ms {run.seconds:>11.2f} s "
            f"{cpu:>10.2f} s "
            f"{check * 1000:>5.1f} ms {len(plan):>5}  {note}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
