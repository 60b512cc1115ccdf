"""Algorithm 11, Repair(Δ, Θ, DOM): diagnose, choose, make the problem, plan, check.

``prepare`` does everything up to the planner call (so ``--problem-out`` can
write the problem even when no plan exists); ``solve`` calls the planner and
checks its plan against the domain's semantics.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from rac.diagnosis import DiagnosisResult, Literal, Theory, diagnose
from rac.repair.choice import choose_bad
from rac.repair.errors import NoRepairPlan
from rac.repair.planner import DEFAULT_TIMEOUT_S, PLANNER, Step, run_planner
from rac.repair.problem import RepairProblem, make_problem, render_problem
from rac.repair.simulate import InapplicableStep, State, check_plan, initial_state
from rac.repair.split import SPLIT_ABOVE, plan_in_parts
from rac.repair.system import RepairSystem, system_from_clauses, system_from_model
from rac.targets.pddl_domain import render_repair_domain


@dataclass(frozen=True, slots=True)
class Prepared:
    """A repair problem ready for the planner."""

    observations: tuple[Literal, ...]
    diagnosis: DiagnosisResult
    strategy: str
    problem: RepairProblem
    domain_text: str
    problem_text: str

    @property
    def bad(self) -> tuple[str, ...]:
        return self.problem.bad

    @property
    def good(self) -> tuple[str, ...]:
        return self.problem.good


@dataclass(frozen=True, slots=True)
class RepairResult:
    prepared: Prepared
    plan: tuple[Step, ...]  # in component names: ("shutdown", "jaguar")
    final: State  # the state after the plan (every component good)
    planner_seconds: float = 0.0

    def to_json(self) -> dict[str, Any]:
        """Contract §7's shape."""
        return {
            "diagnosis": {"bad": list(self.prepared.bad), "good": list(self.prepared.good)},
            "plan": [list(step) for step in self.plan],
            "planner": PLANNER,
        }


def repair_system(theory: Theory) -> RepairSystem:
    if theory.model is not None:
        return system_from_model(theory.model, theory.components)
    return system_from_clauses(theory.clauses, theory.components, theory.nab)


def prepare(
    theory: Theory,
    observations: Sequence[Literal],
    robot: str,
    strategy: str = "minimal",
    diagnosis: DiagnosisResult | None = None,
) -> Prepared:
    """Diagnose Θ (unless given the result), choose the bad set and build the problem."""
    result = diagnosis if diagnosis is not None else diagnose(theory, observations)
    if not result.consistent and not result.diagnoses:
        raise NoRepairPlan(
            "RAC070",
            "no diagnosis explains the observations, so there is nothing to plan a repair for",
            hint="check the observations with 'racc diagnose'; they may contradict each other "
            "or the model",
        )
    system = repair_system(theory)
    names = system.names()
    fixable = set(names) - set(system.unrepairable(names))  # once, not once per component
    repairable = lambda c: c in fixable  # noqa: E731
    bad = () if result.consistent else choose_bad(result.diagnoses, strategy, repairable)
    problem = make_problem(robot, system, observations, bad, theory.neg_prefix)
    return Prepared(
        observations=tuple(observations),
        diagnosis=result,
        strategy=strategy,
        problem=problem,
        domain_text=render_repair_domain(robot),
        problem_text=render_problem(problem),
    )


def solve(prepared: Prepared, timeout_s: float = DEFAULT_TIMEOUT_S) -> RepairResult:
    """Plan the repair; NoRepairPlan when a bad component cannot be repaired or there is no plan."""
    problem = prepared.problem
    if not problem.bad:  # nothing is faulty: no repair needed
        return RepairResult(prepared, (), initial_state(problem))
    stuck = problem.system.unrepairable(problem.bad)
    if stuck:
        raise NoRepairPlan(
            "RAC071",
            f"no repair action can make {', '.join(stuck)} good: "
            f"{'it is' if len(stuck) == 1 else 'they are'} hardware that is not switchable, "
            f"and the diagnosis holds {'it' if len(stuck) == 1 else 'them'} faulty",
            hint="repair it by hand, or declare it switchable (with its board channel) in the "
            "model",
        )
    if len(problem.system.components) > SPLIT_ABOVE:  # in independent parts (rac.repair.split)
        run = plan_in_parts(prepared.domain_text, problem, timeout_s)
    else:
        run = run_planner(prepared.domain_text, prepared.problem_text, timeout_s)
    names = problem.component_of()
    plan = tuple((step[0], *(names.get(a, a) for a in step[1:])) for step in run.plan)
    try:
        final = check_plan(problem, plan)
    except InapplicableStep as err:  # the planner and our semantics disagree: say so loudly
        raise NoRepairPlan(
            "RAC073", f"the planner's plan does not repair the robot: {err}"
        ) from None
    return RepairResult(prepared, plan, final, run.seconds)
