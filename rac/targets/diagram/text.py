"""Text in DOT: every string racc writes into a drawing is quoted or escaped here."""

from __future__ import annotations

import re

_DOT_SPECIAL = re.compile(r'[\\"\r\n]')


def quote(text: str) -> str:
    """A DOT double-quoted string whose escString value is ``text`` verbatim.

    Backslashes are doubled so Graphviz's label escapes (``\\N``, ``\\G``, ``\\l``…) cannot
    fire by accident; a line break becomes DOT's ``\\n``.
    """
    if _DOT_SPECIAL.search(text) is None:
        return f'"{text}"'  # the usual name: nothing to escape
    body = text.replace("\\", "\\\\").replace('"', '\\"')
    return '"' + body.replace("\r\n", "\n").replace("\r", "\n").replace("\n", "\\n") + '"'


def html_text(text: str) -> str:
    """Text for a Graphviz HTML-like label (XML; a line break is ``<BR/>``)."""
    # xml.sax.saxutils.escape's replacements, without its import (urllib: 30 ms of start-up).
    escaped = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return escaped.replace('"', "&quot;").replace("\n", '<BR ALIGN="LEFT"/>')
