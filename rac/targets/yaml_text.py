"""Block-style YAML for the emitters, fast, and byte for byte what PyYAML writes.

``yaml.safe_dump`` spends about 300 µs per observer entry in the pure-Python emitter (and
still a third of that with libyaml, whose representer is Python); a 10,000-node model has
nearly 40,000 observers.  The emitters' documents are simple (mappings, lists, strings and
numbers), and for simple documents PyYAML's block output is easy to predict.  :func:`dump`
writes that output directly and falls back to ``yaml.safe_dump`` for the whole document as
soon as anything is not provably simple: a string PyYAML would quote or fold, an unusual
type, a long key.  So the result is always exactly ``yaml.safe_dump(doc, sort_keys=False,
default_flow_style=False, width=1000)``.
"""

from __future__ import annotations

import re
from typing import Any

import yaml
from yaml.nodes import ScalarNode
from yaml.resolver import Resolver

WIDTH = 1000
# A string PyYAML writes as a plain scalar in block context: no indicator at its start, no
# ': ' or ' #', no leading, trailing or double space, no quote or special character.  The
# implicit resolvers are asked separately (so 'on', 'null' or '1.5' are not plain strings).
_PLAIN = re.compile(r"[A-Za-z_/][A-Za-z0-9_/().,:~+<>=\-]*(?: [A-Za-z0-9_/().,~+<>=\-]+)*")
_STR_TAG = "tag:yaml.org,2002:str"
_RESOLVER = Resolver()


class _NotSimple(Exception):
    pass


def dump(doc: dict[str, Any]) -> str:
    """``yaml.safe_dump(doc, sort_keys=False, default_flow_style=False, width=1000)``."""
    try:
        out: list[str] = []
        _mapping(doc, "", "", out, {})
        return "".join(out)
    except _NotSimple:
        return yaml.safe_dump(doc, sort_keys=False, default_flow_style=False, width=WIDTH)


def _string(value: str, cache: dict[str, str]) -> str:
    text = cache.get(value)
    if text is None:
        if (
            _PLAIN.fullmatch(value) is None
            or value.endswith(":")
            or ": " in value
            or _RESOLVER.resolve(ScalarNode, value, (True, False)) != _STR_TAG  # type: ignore[no-untyped-call]
        ):
            raise _NotSimple
        text = cache[value] = value
    return text


def _float(value: float) -> str:
    # SafeRepresenter.represent_float
    if value != value or value in (float("inf"), float("-inf")):
        raise _NotSimple
    text = repr(value).lower()
    if "." not in text and "e" in text:
        text = text.replace("e", ".0e", 1)
    return text


def _scalar(value: Any, cache: dict[str, str]) -> str:
    kind = type(value)
    if kind is str:
        return _string(value, cache)
    if kind is int:
        return str(value)
    if kind is float:
        return _float(value)
    if kind is bool:
        return "true" if value else "false"
    raise _NotSimple


def _line(out: list[str], prefix: str, text: str) -> None:
    # Past the width PyYAML folds a plain scalar at a space; leave that to PyYAML.  A
    # scalar without spaces cannot be folded and stays on one line, however long.
    if len(prefix) + len(text) >= WIDTH - 2 and " " in text:
        raise _NotSimple
    out.append(prefix + text + "\n")


def _mapping(
    doc: dict[str, Any], indent: str, first: str, out: list[str], cache: dict[str, str]
) -> None:
    """A block mapping whose keys start at ``indent``; the first key's line starts ``first``."""
    if not doc:
        raise _NotSimple
    lead = first
    for key, value in doc.items():
        if type(key) is not str or len(key) > 120:
            raise _NotSimple
        head = lead + _string(key, cache)
        lead = indent
        kind = type(value)
        if kind is dict:
            if not value:
                _line(out, head, ": {}")
            else:
                out.append(head + ":\n")
                _mapping(value, indent + "  ", indent + "  ", out, cache)
        elif kind is list:
            if not value:
                _line(out, head, ": []")
            else:
                out.append(head + ":\n")
                _sequence(value, indent, out, cache)
        else:
            _line(out, head + ": ", _scalar(value, cache))


def _sequence(items: list[Any], indent: str, out: list[str], cache: dict[str, str]) -> None:
    """An indentless block sequence under a mapping key at ``indent``."""
    for item in items:
        kind = type(item)
        if kind is dict:
            _mapping(item, indent + "  ", indent + "- ", out, cache)
        elif kind is list:
            raise _NotSimple
        else:
            _line(out, indent + "- ", _scalar(item, cache))
