"""The repair problem compiled to STRIPS with unified-planning, and pyperplan on it.

pyperplan (``.venv/bin/pip install pyperplan``, a bench peer, never a racc dependency) reads
only STRIPS with typing; the repair domain has negative, universal and disjunctive
preconditions and conditional effects.  unified-planning's own compilers take them away, in
this order (``STEPS``):

1. QUANTIFIERS_REMOVING: each ``forall`` becomes a conjunction over the objects of its type;
2. GROUNDING (``up_grounder``): one action per applicable parameter tuple; the static
   ``drives`` facts are evaluated away, so the ``imply`` and the ``when`` conditions become
   true or false and the conditional effects unconditional;
3. CONDITIONAL_EFFECTS_REMOVING, DISJUNCTIVE_CONDITIONS_REMOVING: left with nothing to do,
   but they certify the problem kind;
4. NEGATIVE_CONDITIONS_REMOVING: ``(not (running n))`` becomes a complement fluent
   ``not_running`` that every effect on ``running`` maintains (and ``not_on`` for ``on``).

Grounding before removing the quantifiers does not work: the conditional effects then still
test ``drives`` and removing them makes 2^(drivers) copies of ``shutdown``.  The compiled
problem is written with PDDLWriter; a plan read back is mapped through each compiler's
``map_back_action_instance`` to the repair domain's actions.
"""

from __future__ import annotations

import resource
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rac.repair.planner import Step, parse_plan, run_bounded

STEP_NAMES = (
    "QUANTIFIERS_REMOVING",
    "GROUNDING",
    "CONDITIONAL_EFFECTS_REMOVING",
    "DISJUNCTIVE_CONDITIONS_REMOVING",
    "NEGATIVE_CONDITIONS_REMOVING",
)
# UP may offer several engines for a kind; these are its own, and the FD grounder (which
# instantiates with up_grounder anyway) names two ground actions alike on this domain.
ENGINES = {"GROUNDING": "up_grounder"}
# The problem-kind features a STRIPS problem (with typing) must not have.
NOT_STRIPS = frozenset(
    [
        "NEGATIVE_CONDITIONS",
        "DISJUNCTIVE_CONDITIONS",
        "EXISTENTIAL_CONDITIONS",
        "UNIVERSAL_CONDITIONS",
        "EQUALITIES",
        "CONDITIONAL_EFFECTS",
        "FORALL_EFFECTS",
    ]
)


@dataclass(frozen=True)
class Strips:
    """A repair problem compiled to STRIPS: its PDDL and how to read a plan back."""

    domain: str
    problem: str
    actions: int  # grounded actions
    facts: int  # ground atoms the actions, the initial state or the goal mention
    seconds: float  # reading the PDDL, the compilers and PDDLWriter
    up_problem: Any
    writer: Any
    map_back: tuple[Callable[[Any], Any], ...]  # the compilers', last compiler first

    def plan_back(self, plan_text: str) -> tuple[Step, ...]:
        """A plan of the STRIPS problem as steps of the repair domain (PDDL object names)."""
        from unified_planning.plans import ActionInstance

        steps: list[Step] = []
        for (name,) in parse_plan(plan_text):
            instance = ActionInstance(self.writer.get_item_named(name))
            for back in self.map_back:
                instance = back(instance)
            steps.append((instance.action.name, *(str(p) for p in instance.actual_parameters)))
        return tuple(steps)


def _atoms(node: Any, into: set[Any]) -> None:
    if node.is_fluent_exp():
        into.add(node)
    for arg in node.args:
        _atoms(arg, into)


def fact_count(problem: Any) -> int:
    atoms: set[Any] = set()
    for action in problem.actions:
        for pre in action.preconditions:
            _atoms(pre, atoms)
        for effect in action.effects:
            _atoms(effect.fluent, atoms)
    atoms.update(f for f, v in problem.initial_values.items() if v.bool_constant_value())
    for goal in problem.goals:
        _atoms(goal, atoms)
    return len(atoms)


def is_strips(kind: Any) -> bool:
    return not NOT_STRIPS & set(kind.features)


def compile_to_strips(domain_text: str, problem_text: str) -> Strips:
    """Compile the repair domain and problem to STRIPS with unified-planning's compilers."""
    from unified_planning.engines import CompilationKind
    from unified_planning.io import PDDLReader, PDDLWriter
    from unified_planning.shortcuts import Compiler, get_environment

    get_environment().credits_stream = None  # its banner would pollute our output
    start = time.perf_counter()
    problem = PDDLReader().parse_problem_string(domain_text, problem_text)
    backs: list[Callable[[Any], Any]] = []
    for step in STEP_NAMES:
        kind = getattr(CompilationKind, step)
        engine = ENGINES.get(step)
        compiler = (
            Compiler(name=engine)
            if engine
            else Compiler(problem_kind=problem.kind, compilation_kind=kind)
        )
        with compiler:
            result = compiler.compile(problem, kind)
        problem = result.problem
        backs.append(result.map_back_action_instance)
    writer = PDDLWriter(problem)
    domain, text = writer.get_domain(), writer.get_problem()
    return Strips(
        domain,
        text,
        len(problem.actions),
        fact_count(problem),
        time.perf_counter() - start,
        problem,
        writer,
        tuple(reversed(backs)),
    )


def pyperplan_command() -> list[str] | None:
    """How to run pyperplan with this Python, or None when it is not installed."""
    import importlib.util

    if importlib.util.find_spec("pyperplan") is None:
        return None
    return [sys.executable, "-m", "pyperplan"]


INSTALL_HINT = "pyperplan is not installed: .venv/bin/pip install pyperplan"


@dataclass(frozen=True)
class PeerRun:
    plan_text: str | None  # None: no plan (time-out or failure), see ``why``
    seconds: float  # wall clock
    cpu: float  # CPU time of the pyperplan process
    why: str = ""


def run_pyperplan(
    strips: Strips, timeout_s: float, search: str = "ehs", heuristic: str = "hff"
) -> PeerRun:
    """pyperplan on the STRIPS problem; enforced hill-climbing on h_FF by default (its
    greedy best-first search evaluates every successor, hours at 1,000 components)."""
    command = pyperplan_command()
    if command is None:
        return PeerRun(None, 0.0, 0.0, INSTALL_HINT)
    with tempfile.TemporaryDirectory(prefix="racc-pyperplan-") as tmp:
        work = Path(tmp)
        (work / "domain.pddl").write_text(strips.domain, encoding="utf-8")
        (work / "problem.pddl").write_text(strips.problem, encoding="utf-8")
        args = ["-s", search, "-H", heuristic, "-l", "warning", "domain.pddl", "problem.pddl"]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.monotonic()
        finished = run_bounded([*command, *args], work, timeout_s)
        seconds = time.monotonic() - start
        output = "" if finished is None else finished[1]
        if finished is None:
            why = f"no plan within {timeout_s:g} s"
        else:
            why = "" if finished[0] == 0 else f"exit code {finished[0]}"
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        solution = work / "problem.pddl.soln"
        if why or not solution.is_file():
            detail = why or (output.strip().splitlines() or ["no plan"])[-1]
            return PeerRun(None, seconds, cpu, detail)
        return PeerRun(solution.read_text(encoding="utf-8"), seconds, cpu)
