"""Text in DOT: every string racc writes into a drawing is quoted or escaped here, and made
safe for Graphviz whatever the model holds.

Graphviz's scanner (2.43) stops at a quoted or HTML-like string of 16,381 bytes or more
("syntax error ... scanning a quoted string (missing endquote? longer than 16384?)"), and an
HTML-like label must be well-formed XML, so a control character in it is an error too.  A
model learned from a live graph of 100 relays had a topic whose tooltip listed its observers
in more than 16 kB: Graphviz refused the whole file.  So:

- every character XML refuses (control characters, lone surrogates, U+FFFE/U+FFFF) is drawn
  as U+FFFD; a valid model has none, a ram/1 JSON file may;
- a quoted string is cut at :data:`MAX_QUOTED_BYTES` bytes with a note of what was cut and a
  digest of the whole, so that two long names cut alike stay two nodes;
- a name drawn in a label is elided in its middle beyond :data:`MAX_SHOWN_CHARS`
  characters (the full name is in the tooltip), and any other text of a label beyond
  :data:`MAX_HTML_TEXT_CHARS`;
- :func:`fits` says whether a finished HTML-like label is within Graphviz's limit, for the
  caption, which grows with the model.
"""

from __future__ import annotations

import hashlib
import re

# Graphviz 2.43 accepts a quoted or HTML-like string of at most 16,380 bytes between its
# delimiters (found by bisection); this is the limit the drawing keeps below.
GRAPHVIZ_STRING_BYTES = 16380
# A tooltip or an id longer than this is cut: 4 kB is 50 lines of a tooltip.
MAX_QUOTED_BYTES = 4096
# A name drawn in a label: longer names are elided in their middle ("/robot…/amcl").
MAX_SHOWN_CHARS = 60
# Any other text of a label (a note, a detail line).
MAX_HTML_TEXT_CHARS = 300

_DOT_SPECIAL = re.compile(r'[\\"\r\n]')
# What XML 1.0 refuses (and NUL, which ends a C string in Graphviz).
_UNSAFE = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
REPLACEMENT = "\ufffd"


def clean(text: str) -> str:
    """``text`` with every character Graphviz or XML refuses drawn as U+FFFD."""
    return _UNSAFE.sub(REPLACEMENT, text) if _UNSAFE.search(text) else text


def _escaped(text: str) -> str:
    body = text.replace("\\", "\\\\").replace('"', '\\"')
    return body.replace("\r\n", "\n").replace("\r", "\n").replace("\n", "\\n")


def quote(text: str) -> str:
    """A DOT double-quoted string whose escString value is ``text`` verbatim.

    Backslashes are doubled so Graphviz's label escapes (``\\N``, ``\\G``, ``\\l``…) cannot
    fire by accident; a line break becomes DOT's ``\\n``.  Beyond MAX_QUOTED_BYTES bytes the
    text is cut (see the module's docstring).
    """
    if _DOT_SPECIAL.search(text) is None and len(text) * 4 <= MAX_QUOTED_BYTES:
        return f'"{clean(text)}"'  # the usual name: nothing to escape, short in any encoding
    text = clean(text)
    body = _escaped(text)
    if len(body.encode("utf-8")) <= MAX_QUOTED_BYTES:
        return f'"{body}"'
    return f'"{_cut(text)}"'


def _cut(text: str) -> str:
    """The escaped head of ``text`` that fits MAX_QUOTED_BYTES with a note of the rest."""
    digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:12]
    low, high = 0, len(text)
    while low < high:  # the longest head whose note still fits
        mid = (low + high + 1) // 2
        note = f"…[+{len(text) - mid:,} characters, #{digest}]"
        if len(_escaped(text[:mid] + note).encode("utf-8")) <= MAX_QUOTED_BYTES:
            low = mid
        else:
            high = mid - 1
    return _escaped(text[:low] + f"…[+{len(text) - low:,} characters, #{digest}]")


def bounded(name: str, limit: int = MAX_QUOTED_BYTES // 8) -> str:
    """``name`` if short; else its head and a digest of the whole, to build an id of two
    names (an arrow's label "A → B") that no cut can break in the middle."""
    if len(name) <= limit:
        return name
    digest = hashlib.sha256(name.encode("utf-8", "surrogatepass")).hexdigest()[:12]
    return f"{name[: limit - 15]}…#{digest}"


def elide(text: str, limit: int = MAX_SHOWN_CHARS) -> str:
    """``text`` of at most ``limit`` characters: a long name keeps its head and, longer, its
    tail (a ROS name's last part says most), with ``…`` between."""
    if len(text) <= limit:
        return text
    tail = (limit - 1) * 2 // 3
    return text[: limit - 1 - tail] + "…" + text[len(text) - tail :]


def html_text(text: str, limit: int = MAX_HTML_TEXT_CHARS) -> str:
    """Text for a Graphviz HTML-like label (XML; a line break is ``<BR/>``), at most
    ``limit`` characters of it."""
    text = clean(elide(text, limit))
    # xml.sax.saxutils.escape's replacements, without its import (urllib: 30 ms of start-up);
    # and a backslash doubled, since Graphviz expands \N, \G… in HTML-like labels too (a
    # node named \N drew its label node's name).
    escaped = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    escaped = escaped.replace("\\", "\\\\")
    return escaped.replace('"', "&quot;").replace("\n", '<BR ALIGN="LEFT"/>')


def shown(name: str) -> str:
    """A name as a label draws it: elided beyond MAX_SHOWN_CHARS, escaped for HTML."""
    return html_text(name, MAX_SHOWN_CHARS)


def fits(label: str) -> bool:
    """Whether an HTML-like label's text (between its ``<`` and ``>``) is within Graphviz's
    limit."""
    return len(label.encode("utf-8")) <= GRAPHVIZ_STRING_BYTES
