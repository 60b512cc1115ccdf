"""repair_domain.pddl: the typed PDDL repair domain (§7.1.2.1, docs/spec.md).

The domain is the same for every robot but for its name: which node drives
which device is a fact of the problem (``drives``), written by the repair
problem generator (``rac.repair.problem``) from the model.
"""

from __future__ import annotations

from rac.logic import mangle
from rac.pipeline import Compiled
from rac.targets.options import EmitOptions
from rac.targets.templating import render


def domain_name(robot: str) -> str:
    return f"repair_{mangle(robot).lower()}"


def render_repair_domain(robot: str) -> str:
    """The domain text for a robot named ``robot``; the repair engine plans with it."""
    return render("repair_domain.pddl.j2", robot=robot, domain=domain_name(robot))


def emit_repair_domain(compiled: Compiled, options: EmitOptions) -> str:
    return render_repair_domain(compiled.model.name.value)
