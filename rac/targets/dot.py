"""architecture.dot: the target ``racc compile`` writes, drawn by :mod:`rac.targets.diagram`.

The drawing's code lives in that package (what is drawn, how text is made safe for
Graphviz, the layout's choices); this module is the target of the registry, and keeps the
names other modules and files import from it.
"""

from __future__ import annotations

from rac.pipeline import Compiled
from rac.targets.diagram import (
    MAX_RELATIONS_SHOWN,
    SUMMARY_ABOVE_NODES,
    Drawing,
    View,
    draw_diagram,
    emit_diagram,
    html_text,
    quote,
    summarised,
)
from rac.targets.options import EmitOptions

__all__ = [
    "MAX_RELATIONS_SHOWN",
    "SUMMARY_ABOVE_NODES",
    "Drawing",
    "View",
    "draw_diagram",
    "emit_diagram",
    "emit_dot",
    "html_text",
    "quote",
    "summarised",
]


def emit_dot(compiled: Compiled, options: EmitOptions) -> str:
    """architecture.dot: the reviewer's view, or the summary of a large robot (summarised)."""
    view = View(summary=summarised(compiled.model), undetected=options.undetected)
    return emit_diagram(compiled.model, compiled.observers, view)
