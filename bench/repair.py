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

Issue 14's figures: ``--split-check N`` plans the N-component power-up in independent parts
(rac.repair.split, batches of ``--batch`` components) and validates the joined plan with
unified-planning against the whole problem's PDDL; ``--scenario-10k`` times
``racc scenario model.yaml power-up`` end to end, in a fresh process, on bench/compile.py's
10,000-node robot (the issue's bar: under 60 s).

The peer: ``--peer pyperplan`` also compiles each problem to STRIPS with unified-planning's
compilers (bench/strips.py: quantifiers removed, grounded, negative preconditions made
complement fluents) and runs pyperplan on it (``--pyperplan-search``, enforced hill-climbing
on h_FF by default) under the same ``--timeout``, printing its figures under racc's: the
compilation, pyperplan's wall clock and CPU time, the plan length, and whether its plan, read
back to the repair domain's actions, passes racc's check and unified-planning's validator
against the original problem.  pyperplan is not a racc dependency:
``.venv/bin/pip install pyperplan``.
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
    InapplicableStep,
    NoRepairPlan,
    RepairProblem,
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
    parser.add_argument("--split-check", type=int, metavar="N", help="plan N in parts, validate")
    parser.add_argument("--batch", type=int, default=100, help="--split-check's batch size")
    parser.add_argument("--scenario-10k", action="store_true", help="racc scenario, 10k nodes")
    parser.add_argument("--peer", choices=["pyperplan"], help="also run a peer planner")
    parser.add_argument(
        "--pyperplan-search", default="ehs", help="pyperplan's -s (ehs, gbf, astar...)"
    )
    args = parser.parse_args()
    if args.split_check:
        return split_check(args.split_check, args.batch, args.timeout)
    if args.scenario_10k:
        return scenario_10k()
    if args.peer:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from strips import INSTALL_HINT, pyperplan_command

        if pyperplan_command() is None:
            print(f"--peer pyperplan: {INSTALL_HINT}; racc's figures only")
            args.peer = None
        else:
            print(
                "peer rows: problem gen = the STRIPS compilation (unified-planning), "
                "check = racc's check and unified-planning's validator of the plan read back"
            )
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
        if args.peer:
            peer(problem, domain, text, args.timeout, args.pyperplan_search)
    return 0


def peer(problem: RepairProblem, domain: str, text: str, timeout: float, search: str) -> None:
    """pyperplan on the STRIPS compilation, one line under racc's: same columns, the
    compilation in place of the problem generation, and the plan's validity."""
    from strips import compile_to_strips, run_pyperplan

    from rac.repair.validate import validate_plan

    strips = compile_to_strips(domain, text)
    run = run_pyperplan(strips, timeout, search=search)
    size = f"STRIPS {strips.actions} actions, {strips.facts} facts"
    if run.plan_text is None:
        print(
            f"{'peer':>6} {strips.seconds:>10.1f} s {run.seconds:>11.2f} s {run.cpu:>10.2f} s "
            f"{'':>8} {'-':>5}  pyperplan -s {search}: {run.why}; {size}"
        )
        return
    names = problem.component_of()
    plan = tuple((s[0], *(names[a] for a in s[1:])) for s in strips.plan_back(run.plan_text))
    start = time.perf_counter()
    try:
        check_plan(problem, plan)
        validate_plan(domain, text, problem, plan)
        verdict = "valid"
    except (InapplicableStep, NoRepairPlan) as err:
        verdict = f"INVALID ({err})"
    check = time.perf_counter() - start
    print(
        f"{'peer':>6} {strips.seconds:>10.1f} s {run.seconds:>11.2f} s {run.cpu:>10.2f} s "
        f"{check:>6.1f} s {len(plan):>5}  pyperplan -s {search}: {verdict}; {size}"
    )


def split_check(size: int, batch: int, timeout: float) -> int:
    from rac.repair.split import parts, plan_in_parts
    from rac.repair.validate import validate_plan

    compiled = compile_model(synthetic_robot(size))
    theory = Theory(compiled.rbm, compiled.props, compiled.components, model=compiled.model)
    system = repair_system(theory)
    faulty = power_up(system).faulty
    problem = make_problem("synthetic", system, observations(theory, faulty), faulty)
    domain = render_repair_domain("synthetic")
    start = time.perf_counter()
    run = plan_in_parts(domain, problem, timeout, batch=batch)
    planned = time.perf_counter() - start
    names = problem.component_of()
    plan = tuple((s[0], *(names[a] for a in s[1:])) for s in run.plan)
    check_plan(problem, plan)
    start = time.perf_counter()
    validate_plan(domain, render_problem(problem), problem, plan)
    print(
        f"{len(system.components)} components in {len(parts(system))} parts, batches of "
        f"{batch}: planned in {planned:.2f} s, {len(plan)} steps; valid as a whole "
        f"(unified-planning, {time.perf_counter() - start:.1f} s)"
    )
    return 0


def scenario_10k() -> int:
    import subprocess
    import tempfile

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from compile import synthetic_model

    from rac.targets import EmitOptions
    from rac.targets.model_yaml import emit_model_yaml

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "synthetic10000" / "model.yaml"
        path.parent.mkdir()
        path.write_text(emit_model_yaml(compile_model(synthetic_model(10_000)), EmitOptions()))
        command = [sys.executable, "-m", "rac", "scenario", str(path), "power-up", "--json"]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, check=True)
        took = time.perf_counter() - start
    import json

    doc = json.loads(done.stdout)
    print(
        f"racc scenario power-up, 10,000 nodes: {len(doc['diagnosis']['bad'])} bad, "
        f"{len(doc['plan'])} steps, {took:.1f} s end to end (bar: under 60 s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
