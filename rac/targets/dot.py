"""architecture.dot: the Graphviz diagram (Figure 3.1's conventions)."""

from __future__ import annotations

from rac.pipeline import Compiled
from rac.targets import EmitOptions
from rac.targets.templating import render


def emit_dot(compiled: Compiled, options: EmitOptions) -> str:
    model = compiled.model
    return render("architecture.dot.j2", model=model, publishers=model.publishers())
