"""architecture.html: the drawing for a browser, self-contained (docs/diagrams.md).

Graphviz's SVG goes inline with a small script of racc's own (in the template): pan,
zoom, search a name, and a tooltip with what watches each component, from the tooltips
:mod:`rac.targets.dot` writes.  Nothing is fetched, so the file opens without a network.
The SVG is rendered by a command (Graphviz is a program); this module only wraps it.
"""

from __future__ import annotations

import re

from rac.targets.templating import render

# Graphviz's SVG opens with an XML declaration, a DOCTYPE and comments: HTML takes the
# <svg> element alone.
_SVG_START = re.compile(r"<svg\b")


def emit_html(svg: str, title: str) -> str:
    """The HTML page around ``svg`` (Graphviz's output); pure."""
    start = _SVG_START.search(svg)
    if start is None:
        raise ValueError("not an SVG drawing: no <svg> element")
    escaped = title.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return render("architecture.html.j2", title=escaped, svg=svg[start.start() :].rstrip())
