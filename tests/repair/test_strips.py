"""bench/strips.py: the repair problem compiled to STRIPS, and pyperplan's plan for it read back
and checked against the original problem (bench/repair.py --peer pyperplan on bigger robots)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from rac.diagnosis import Theory, predict
from rac.pipeline import compile_model
from rac.repair import check_plan, make_problem, render_problem, repair_system
from rac.repair.problem import RepairProblem
from rac.repair.scenario import power_up
from rac.repair.validate import validate_plan
from rac.targets.pddl_domain import render_repair_domain

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
from repair import synthetic_robot  # bench/repair.py's robot
from strips import compile_to_strips, is_strips, pyperplan_command, run_pyperplan


def _problem(scenario: str) -> RepairProblem:
    compiled = compile_model(synthetic_robot(10))
    theory = Theory(compiled.rbm, compiled.props, compiled.components, model=compiled.model)
    system = repair_system(theory)
    if scenario == "power-up":  # everything off and stopped: start_node and power_up
        faulty = power_up(system).faulty
        return make_problem("synthetic", system, predict(theory, faulty), faulty)
    # a device still on and its running driver bad, plus a running node: all four actions
    return make_problem("synthetic", system, (), ("dev0", "driver0", "proc3"))


@pytest.mark.parametrize("scenario", ["power-up", "running-and-on"])
def test_strips_compilation_is_strips_and_pyperplan_plans_validly(scenario: str) -> None:
    problem = _problem(scenario)
    domain, text = render_repair_domain("synthetic"), render_problem(problem)
    strips = compile_to_strips(domain, text)
    from unified_planning.io import PDDLReader

    assert not is_strips(PDDLReader().parse_problem_string(domain, text).kind)
    assert is_strips(strips.up_problem.kind)
    # 10 components: 8 nodes (stop, start) and 2 devices (shutdown, power_up), ground
    assert strips.actions == 20
    assert all(not a.parameters for a in strips.up_problem.actions)
    assert "(:requirements :strips :typing)" in strips.domain
    for word in ("forall", "exists", "when", "imply", "(or "):
        assert word not in strips.domain
    preconditions = re.findall(r":precondition (.*)", strips.domain)
    assert len(preconditions) == 20 and not any("(not " in p for p in preconditions)
    # the negative preconditions became complement fluents maintained by the effects
    assert "not_running" in strips.domain and "not_on" in strips.domain
    if pyperplan_command() is None:
        pytest.skip("pyperplan is not installed (pip install pyperplan)")
    run = run_pyperplan(strips, 60.0)
    assert run.plan_text is not None, run.why
    plan = strips.plan_back(run.plan_text)
    assert {s[0] for s in plan} <= {"stop_node", "start_node", "shutdown", "power_up"}
    if scenario != "power-up":
        assert {s[0] for s in plan} == {"stop_node", "start_node", "shutdown", "power_up"}
    names = problem.component_of()
    assert not check_plan(problem, tuple((s[0], *(names[a] for a in s[1:])) for s in plan)).bad
    validate_plan(domain, text, problem, tuple((s[0], *(names[a] for a in s[1:])) for s in plan))
