"""Repair (chapter 7): repair problems from diagnoses, planned by Fast Downward.

``prepare``/``solve`` are Algorithm 11; ``run_scenario`` runs the experiments of §10.1.
"""

from __future__ import annotations

from rac.repair.choice import STRATEGIES, choose_bad
from rac.repair.engine import Prepared, RepairResult, prepare, repair_system, solve
from rac.repair.errors import NoRepairPlan
from rac.repair.planner import DEFAULT_TIMEOUT_S, PLANNER, Step, parse_plan, run_planner
from rac.repair.problem import RepairProblem, make_problem, render_problem
from rac.repair.scenario import SCENARIOS, Scenario, ScenarioResult, run_scenario
from rac.repair.simulate import InapplicableStep, State, apply_step, check_plan, simulate
from rac.repair.system import Kind, RepairSystem, system_from_clauses, system_from_model

__all__ = [
    "DEFAULT_TIMEOUT_S",
    "PLANNER",
    "SCENARIOS",
    "STRATEGIES",
    "InapplicableStep",
    "Kind",
    "NoRepairPlan",
    "Prepared",
    "RepairProblem",
    "RepairResult",
    "RepairSystem",
    "Scenario",
    "ScenarioResult",
    "State",
    "Step",
    "apply_step",
    "check_plan",
    "choose_bad",
    "make_problem",
    "parse_plan",
    "prepare",
    "render_problem",
    "repair_system",
    "run_planner",
    "run_scenario",
    "simulate",
    "solve",
    "system_from_clauses",
    "system_from_model",
]
