"""The shared Jinja2 environment: strict, deterministic, trailing newline kept."""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable
from typing import Any

import jinja2

XML_SPECIAL = re.compile("[&<>\"'\n\r\t]")  # what quoteattr would change


def xmlattr(value: object) -> str:
    """``quoteattr(str(value))``, without its six replace calls for the usual plain value."""
    text = str(value)
    if XML_SPECIAL.search(text) is None:
        return f'"{text}"'
    from xml.sax.saxutils import quoteattr  # imports urllib (30 ms): only when needed

    return quoteattr(text)


def xmlparams(params: Iterable[tuple[object, object]]) -> str:
    """``<param name=… value=…/>`` lines, one per parameter, for a launch file's node.

    One filter call per node rather than a template loop per parameter: a large model has
    a quarter of a million parameters.
    """
    return "".join(f"    <param name={xmlattr(k)} value={xmlattr(v)}/>\n" for k, v in params)


@functools.cache
def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("rac.targets", "templates"),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters["xmlattr"] = xmlattr
    env.filters["xmlparams"] = xmlparams
    return env


def render(template: str, **context: Any) -> str:
    return environment().get_template(template).render(**context)
