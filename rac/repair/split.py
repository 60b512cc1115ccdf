"""Planning a large repair in independent parts (issue 14).

In the repair domain an action on a node reads and changes only that node and the devices
it drives, and an action on a device changes only the device and its drivers.  So the
components fall into parts linked by ``drives`` (which node drives which device), and the
actions of one part never touch another's facts: plans of the parts, one after the other,
are a plan of the whole, and the whole plan is still checked against the domain's
semantics (``rac.repair.simulate.check_plan``) by the caller.  Data flow (topics) does not
appear in the domain, so it links nothing here.

Fast Downward's time grows faster than the problem (127 s for 11,000 components in one
problem, about 1 s for 1,000), so parts are packed into batches of at most
:data:`BATCH_COMPONENTS` components, planned in parallel, one planner process per core.
A problem of at most :data:`SPLIT_ABOVE` components is planned whole, as before.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

from rac.repair.planner import DEFAULT_SEARCH, PlannerRun, Step, run_planner
from rac.repair.problem import RepairProblem, render_problem
from rac.repair.system import RepairSystem

SPLIT_ABOVE = 2_000
BATCH_COMPONENTS = 1_000


def parts(system: RepairSystem) -> list[list[str]]:
    """The components grouped by ``drives`` (union-find), each part sorted, parts by first name."""
    parent = {c: c for c in system.names()}

    def root(c: str) -> str:
        while parent[c] != c:
            parent[c] = parent[parent[c]]  # path halving: near-constant time per look-up
            c = parent[c]
        return c

    for node, device in system.drives:
        a, b = root(node), root(device)
        if a != b:
            parent[max(a, b)] = min(a, b)
    groups: dict[str, list[str]] = {}
    for c in system.names():  # sorted, so each part is sorted too
        groups.setdefault(root(c), []).append(c)
    return sorted(groups.values())


def batches(groups: Sequence[Sequence[str]], size: int) -> list[list[str]]:
    """Whole parts packed in order into batches of about ``size`` components."""
    out: list[list[str]] = []
    current: list[str] = []
    for group in groups:
        if current and len(current) + len(group) > size:
            out.append(current)
            current = []
        current.extend(group)
    if current:
        out.append(current)
    return out


def restrict(problem: RepairProblem, components: Sequence[str]) -> RepairProblem:
    """The repair problem of ``components`` alone (a union of parts)."""
    keep = set(components)
    system = problem.system
    return RepairProblem(
        robot=problem.robot,
        system=RepairSystem(
            components=tuple((c, k) for c, k in system.components if c in keep),
            drives=tuple((n, d) for n, d in system.drives if n in keep),
        ),
        running=tuple(c for c in problem.running if c in keep),
        on=tuple(c for c in problem.on if c in keep),
        bad=tuple(c for c in problem.bad if c in keep),
        observations=(),  # only a comment of the whole problem's text
        names=tuple((c, p) for c, p in problem.names if c in keep),
    )


Planner = Callable[[str, str, float], PlannerRun]


def plan_in_parts(
    domain: str,
    problem: RepairProblem,
    timeout_s: float,
    batch: int = BATCH_COMPONENTS,
    workers: int | None = None,
    planner: Planner | None = None,
) -> PlannerRun:
    """One plan for ``problem`` from plans of its batches of parts, planned in parallel.

    Only batches holding a bad component are planned.  The plan's steps name PDDL objects,
    as the planner's own do; NoRepairPlan from any batch is the whole problem's.
    """
    plan_batch = planner or (lambda d, p, t: run_planner(d, p, t, DEFAULT_SEARCH))
    bad = set(problem.bad)
    todo = [b for b in batches(parts(problem.system), batch) if bad.intersection(b)]
    texts = [render_problem(restrict(problem, b)) for b in todo]
    start = time.monotonic()
    deadline = start + timeout_s

    def one(text: str) -> PlannerRun:
        # each batch gets what is left of the whole problem's time
        return plan_batch(domain, text, max(1.0, deadline - time.monotonic()))

    count = workers or min(len(texts), os.cpu_count() or 1) or 1
    with ThreadPoolExecutor(max_workers=count) as pool:
        runs = list(pool.map(one, texts))  # in batch order; the first failure is raised
    steps: list[Step] = [step for run in runs for step in run.plan]
    return PlannerRun(tuple(steps), time.monotonic() - start)
