"""``--validate``: check a plan with unified-planning's sequential plan validator.

unified-planning is an optional extra (``pip install racc[validate]``); it
reads the same domain and problem text the planner read, so it checks the
plan independently of both the planner and ``rac.repair.simulate``.
"""

from __future__ import annotations

import functools
from typing import Any

from rac.repair.errors import NoRepairPlan
from rac.repair.planner import Step
from rac.repair.problem import RepairProblem


def plan_text(problem: RepairProblem, plan: tuple[Step, ...]) -> str:
    """The plan in ``sas_plan`` form, in PDDL object names."""
    names = dict(problem.names)
    return "".join(f"({' '.join([s[0], *(names[a] for a in s[1:])])})\n" for s in plan)


@functools.lru_cache(maxsize=4)
def _parsed(domain_text: str, problem_text: str) -> tuple[Any, Any]:
    """unified-planning's reader and problem, parsed once for several plans."""
    from unified_planning.io import PDDLReader

    reader = PDDLReader()
    return reader, reader.parse_problem_string(domain_text, problem_text)


def validate_plan(
    domain_text: str, problem_text: str, problem: RepairProblem, plan: tuple[Step, ...]
) -> None:
    """Return when the plan is valid; raise NoRepairPlan saying why when it is not."""
    try:
        from unified_planning.engines import ValidationResultStatus
        from unified_planning.exceptions import UPException
        from unified_planning.io import PDDLReader  # noqa: F401  (fail here when missing)
        from unified_planning.shortcuts import PlanValidator, get_environment
    except ImportError:
        raise NoRepairPlan(
            "RAC077",
            "cannot validate the plan: unified-planning is not installed",
            hint="install it with: pip install 'unified-planning>=1.1' (the 'validate' extra), "
            "or leave out --validate",
        ) from None
    get_environment().credits_stream = None  # its banner would pollute our output
    try:
        reader, up_problem = _parsed(domain_text, problem_text)
        up_plan = reader.parse_plan_string(up_problem, plan_text(problem, plan))
    except UPException as err:
        raise NoRepairPlan(
            "RAC078", f"cannot validate the plan: unified-planning cannot read it: {err}"
        ) from None
    with PlanValidator(problem_kind=up_problem.kind, plan_kind=up_plan.kind) as validator:
        result = validator.validate(up_problem, up_plan)
    if result.status is not ValidationResultStatus.VALID:
        why = "; ".join(m.message for m in result.log_messages or ()) or str(result.reason)
        raise NoRepairPlan("RAC078", f"the plan is not valid: {why}")
