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
from collections.abc import Collection
from typing import Any

import yaml

WIDTH = 1000
# A string PyYAML writes as a plain scalar in block context: no indicator at its start, no
# ': ' or ' #', no leading, trailing or double space, no quote or special character.  The
# implicit resolvers are asked separately (so 'on', 'null' or '1.5' are not plain strings).
_PLAIN = re.compile(r"[A-Za-z_/][A-Za-z0-9_/().,:~+<>=\-]*(?: [A-Za-z0-9_/().,~+<>=\-]+)*")
# PyYAML's implicit resolvers (bool, int, float, null, timestamp, ...), by first character.
_RESOLVERS: dict[Any, list[tuple[str, re.Pattern[str]]]] = yaml.SafeDumper.yaml_implicit_resolvers
_WILDCARD = tuple(regexp for _tag, regexp in _RESOLVERS.get(None, []))
_IMPLICIT = {
    first: (*(regexp for _tag, regexp in resolvers), *_WILDCARD)
    for first, resolvers in _RESOLVERS.items()
    if first is not None
}
_LONG = WIDTH - 200  # below this length no line can reach the width


def _safe_pattern() -> re.Pattern[str]:
    """One regex matching exactly the strings :func:`_plain` accepts.

    ``_PLAIN`` with its first word never ending in ':' (so no ': ' and no trailing ':'),
    behind a lookahead that rejects whatever an implicit resolver for the string's first
    character (or a wildcard resolver, for any other first character) would match.
    """
    word, first_word = r"[A-Za-z0-9_/().,~+<>=\-]", r"[A-Za-z0-9_/().,:~+<>=\-]"
    plain = rf"[A-Za-z_/](?:{first_word}*{word})?(?: {word}+)*"

    def any_of(regexps: tuple[re.Pattern[str], ...]) -> str:
        return "|".join(f"(?x:{r.pattern})" for r in regexps) or "(?!)"

    # First characters grouped by their resolvers ('' is never a first character).
    groups: dict[tuple[re.Pattern[str], ...], str] = {}
    for first, regexps in _IMPLICIT.items():
        if first:
            groups[regexps] = groups.get(regexps, "") + re.escape(first)
    branches = [f"(?=[{firsts}])(?:{any_of(regexps)})" for regexps, firsts in groups.items()]
    firsts = "".join(re.escape(first) for first in _IMPLICIT if first)
    if _WILDCARD:
        branches.append(f"(?![{firsts}])(?:{any_of(_WILDCARD)})")
        guard = ""
    else:
        guard = f"(?=[{firsts}])"  # no resolver for any other first character: done
    return re.compile(f"(?!{guard}(?:{'|'.join(branches)})){plain}" if branches else plain)


# ``_SAFE.fullmatch(s)`` is ``_plain(s)`` without the exception: one C call per string.
_SAFE = _safe_pattern()
# Not None when a string is written as a plain scalar that YAML reads back as this string
# (rac.load.observers_yaml reads the strings racc writes with it).
plain_string = _SAFE.fullmatch


class NotSimple(Exception):
    """The document (or a value) is not one this module can write exactly as PyYAML."""


_NotSimple = NotSimple


def scalar(value: Any, strings: dict[Any, str]) -> str:
    """The plain text of a string or number in a block mapping or sequence.

    Raises :class:`NotSimple` for anything :func:`dump` would leave to PyYAML, including a
    string so long that PyYAML might fold its line.  ``strings`` caches plain strings.
    """
    if type(value) is str:
        text = strings.get(value)
        if text is None:
            text = _plain(value)
            if len(text) > _LONG and " " in text:
                raise NotSimple
            strings[value] = text  # so a hit in ``strings`` is always safe to use as is
        return text
    return _number(value)


def dump(doc: dict[str, Any]) -> str:
    """``yaml.safe_dump(doc, sort_keys=False, default_flow_style=False, width=1000)``."""
    try:
        out: list[str] = []
        if type(doc) is not dict:
            raise _NotSimple
        _mapping(doc, "", "", out, {})
        return "".join(out)
    except _NotSimple:
        return yaml.safe_dump(doc, sort_keys=False, default_flow_style=False, width=WIDTH)


def check_plain(strings: Collection[str]) -> None:
    """NotSimple unless :func:`scalar` writes each of ``strings`` (all str) as itself.

    :func:`scalar` writes a plain string as itself, so an emitter may write strings first
    and have them checked here all at once: one regex call per item (pass each string once
    if many repeat).
    """
    if not all(map(_SAFE.fullmatch, strings)):
        raise _NotSimple
    if strings and max(map(len, strings)) > _LONG:
        for text in strings:
            if len(text) > _LONG and " " in text:
                raise _NotSimple


def plain_list(key: str, items: list[str]) -> str:
    """``dump({key: items})`` for a list of strings, or NotSimple when unsure.

    One regex call per item and one join: model.yaml lists a hundred thousand atoms and
    rules, nearly all distinct, so a cache would not pay for itself.
    """
    if type(key) is not str or len(key) > 120 or _SAFE.fullmatch(key) is None:
        raise _NotSimple
    if not items:
        return f"{key}: []\n"
    if not all(type(item) is str for item in items) or not all(map(_SAFE.fullmatch, items)):
        raise _NotSimple
    if max(map(len, items)) > _LONG:
        for item in items:
            if len(item) > _LONG:
                _fold_check("- ", item)
    return f"{key}:\n- " + "\n- ".join(items) + "\n"


def _plain(value: str) -> str:
    """``value`` when PyYAML writes it as a plain scalar that reads back as this string."""
    if _SAFE.fullmatch(value) is None:
        raise _NotSimple
    return value


def _number(value: Any) -> str:
    """SafeRepresenter's text for an int, float or bool (plain in the output)."""
    kind = type(value)
    if kind is int:
        return str(value)
    if kind is bool:
        return "true" if value else "false"
    if kind is not float or value != value or value in (float("inf"), float("-inf")):
        raise _NotSimple
    text = repr(value).lower()
    if "." not in text and "e" in text:
        text = text.replace("e", ".0e", 1)
    return text


def _fold_check(head: str, text: str) -> None:
    # Past the width PyYAML folds a plain scalar at a space; leave that to PyYAML.  A
    # scalar without spaces cannot be folded and stays on one line, however long.
    if " " in text and len(head) + len(text) >= WIDTH - 2:
        raise _NotSimple


def _mapping(
    doc: dict[Any, Any], indent: str, first: str, out: list[str], strings: dict[str, str]
) -> None:
    """A block mapping whose keys start at ``indent``; the first key's line starts ``first``.

    ``strings`` caches the text of every string already found plain.
    """
    if not doc:
        raise _NotSimple
    append = out.append
    lead = first
    for key, value in doc.items():
        k = strings.get(key)
        if k is None or len(k) > 120:  # PyYAML writes a long key as a complex '? key'
            if type(key) is not str or len(key) > 120:
                raise _NotSimple
            k = strings[key] = _plain(key)
        head = lead + k
        lead = indent
        kind = type(value)
        if kind is str:
            text = strings.get(value)
            if text is None:
                text = strings[value] = _plain(value)
            if len(text) > _LONG:
                _fold_check(head + ": ", text)
            append(f"{head}: {text}\n")
        elif kind is dict:
            if not value:
                append(head + ": {}\n")
            else:
                append(head + ":\n")
                _mapping(value, indent + "  ", indent + "  ", out, strings)
        elif kind is list:
            if not value:
                append(head + ": []\n")
            else:
                append(head + ":\n")
                _sequence(value, indent, out, strings)
        else:
            append(f"{head}: {_number(value)}\n")


def _sequence(items: list[Any], indent: str, out: list[str], strings: dict[str, str]) -> None:
    """An indentless block sequence under a mapping key at ``indent``."""
    append = out.append
    dash = indent + "- "
    for item in items:
        kind = type(item)
        if kind is str:
            text = strings.get(item)
            if text is None:
                text = strings[item] = _plain(item)
            if len(text) > _LONG:
                _fold_check(dash, text)
            append(f"{dash}{text}\n")
        elif kind is dict:
            _mapping(item, indent + "  ", dash, out, strings)
        elif kind is list:
            raise _NotSimple
        else:
            append(f"{dash}{_number(item)}\n")
