"""The documented limits on every input (docs/language.md, "Limits"), checked in one place.

racc reads files written by hand, by other tools and by hostile users alike.  Whatever the
input, it either succeeds or reports a located error with a code; these limits keep every
accepted model writable and readable back, and every run linear in its input:

* numbers (RAC007): at most :data:`MAX_NUMBER_CHARS` characters, finite, of magnitude at
  most :data:`NUMBER_MAX`, and a rate's period and interval deviation finite too;
* names (RAC008): ASCII from a documented set per kind, at most :data:`MAX_NAME` characters;
* JSON and YAML documents (RAC009): at most :data:`MAX_DOCUMENT_BYTES` and nested at most
  :data:`MAX_DEPTH` deep; YAML anchors and aliases are not accepted.
"""

from __future__ import annotations

import contextlib
import math
import re
from collections.abc import Iterator
from typing import Any

import yaml

from rac.errors import Diagnostic, RacError, Span

MAX_NUMBER_CHARS = 40
NUMBER_MAX = 1e15
MAX_NAME = 255
MAX_DEPTH = 64
MAX_DOCUMENT_BYTES = 64 * 1024 * 1024
# model.yaml is read by PyYAML, whose composer is slow (about a second a megabyte with libyaml):
# a generated model.yaml of a 10,000-node robot is about 2 MB.
MAX_YAML_BYTES = 16 * 1024 * 1024
# Any text file racc reads (a model, observations, a properties CSV): a recording or a device
# given by mistake is refused before it fills the memory.
MAX_INPUT_BYTES = 256 * 1024 * 1024

RANGE = f"finite and at most {NUMBER_MAX:g} in magnitude"


def number_problem(value: float | int) -> str | None:
    """Why ``value`` breaks the number limits, or None when it is fine."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return None if abs(value) <= NUMBER_MAX else f"out of range (numbers are {RANGE})"
    if not math.isfinite(value):
        return f"not a finite number (numbers are {RANGE})"
    if abs(value) > NUMBER_MAX:
        return f"out of range (numbers are {RANGE})"
    return None


def number_text_problem(text: str) -> str | None:
    """:func:`number_problem` for a number as written (never converts an overlong one)."""
    if len(text) > MAX_NUMBER_CHARS:
        return f"a number of {len(text):,} characters (at most {MAX_NUMBER_CHARS})"
    try:
        value = float(text)
    except ValueError:
        return None  # not a number after all: the parser says what it is
    return number_problem(value)


# A number of the .ram language wherever one can stand: not inside a name (which may hold
# digits, '-' and '.') and not in a comment.  One pass, linear in the text.
_RAM_NUMBER = re.compile(
    r"#[^\n]*|(?<![A-Za-z0-9_~/\-.])[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?"
)


def ram_number_problems(text: str, path: str) -> list[Diagnostic]:
    """RAC007 for every number of a .ram text outside the limits, located."""
    found: list[Diagnostic] = []
    line, line_start, at = 1, 0, 0
    for match in _RAM_NUMBER.finditer(text):
        token = match.group()
        if token.startswith("#"):
            continue
        problem = number_text_problem(token)
        if problem is None:
            continue
        start = match.start()
        newlines = text.count("\n", at, start)
        if newlines:
            line += newlines
            line_start = text.rindex("\n", at, start) + 1
        at = start
        column = start - line_start + 1
        span = Span(path, line, column, line, column + len(token))
        shown = token if len(token) <= 24 else token[:20] + "…"
        found.append(Diagnostic("RAC007", f"number {shown}: {problem}", span))
    return found


def depth_exceeds(value: Any, limit: int = MAX_DEPTH) -> bool:
    """True when lists and objects nest deeper than ``limit`` (iterative: no recursion)."""
    stack: list[tuple[Any, int]] = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict):
            children: Iterator[Any] = iter(item.values())
        elif isinstance(item, list):
            children = iter(item)
        else:
            continue
        if depth > limit:
            return True
        stack.extend((child, depth + 1) for child in children)
    return False


# Names, by kind.  Node and topic names are ROS names (RAC028, rac.passes.validate); the
# others are checked here (RAC008) so that every atom, launch file and model.yaml racc
# writes reads back.
_IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
NAME_SETS: dict[str, tuple[re.Pattern[str], str]] = {
    "field": (
        re.compile(rf"{_IDENT}(?:\.{_IDENT})*"),
        "identifiers (letters, digits, '_', not starting with a digit) joined by '.'",
    ),
    "message type": (
        re.compile(rf"{_IDENT}(?:/{_IDENT})+"),
        "identifiers joined by '/', such as sensor_msgs/LaserScan",
    ),
    "device": (
        re.compile(r"/?[A-Za-z_][A-Za-z0-9_\-]*(?:/[A-Za-z_][A-Za-z0-9_\-]*)*"),
        "letters, digits, '_' and '-' in segments separated by '/', "
        "each starting with a letter or '_'",
    ),
}


def name_problem(kind: str, value: str) -> str | None:
    """Why ``value`` is not a valid name of ``kind`` (a key of :data:`NAME_SETS`), or None."""
    if len(value) > MAX_NAME:
        return f"is {len(value):,} characters long (at most {MAX_NAME})"
    pattern, allowed = NAME_SETS[kind]
    if pattern.fullmatch(value) is None:
        return f"is not made of {allowed}"
    return None


def shown_name(value: str) -> str:
    """A name quoted for a message: escaped (control characters, lone surrogates), cut short."""
    text = value if len(value) <= 60 else value[:60]
    quoted = ascii(text) if not text.isprintable() or not text.isascii() else repr(text)
    return quoted + (f"… ({len(value):,} characters)" if len(value) > 60 else "")


_YAML_LOADER: type = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class YamlLimit(Exception):
    """A YAML document beyond the limits (RAC009), with where it was found."""

    def __init__(self, message: str, mark: Any) -> None:
        super().__init__(message)
        self.message, self.mark = message, mark


def yaml_error_span(err: yaml.YAMLError, file: str) -> Span | None:
    """Where PyYAML or libyaml found ``err`` in ``file``, when it says."""
    mark = getattr(err, "problem_mark", None) or getattr(err, "context_mark", None)
    if mark is None:
        return None
    return Span(file, mark.line + 1, mark.column + 1, mark.line + 1, mark.column + 2)


def yaml_error_diagnostic(
    err: yaml.YAMLError, file: str, code: str, hint: str | None = None
) -> Diagnostic:
    """A text that is not YAML, as the diagnostic ``code`` of its reader, located: the one
    conversion of PyYAML's errors every YAML reader of racc uses."""
    problem = getattr(err, "problem", None) or str(err)
    return Diagnostic(code, f"not valid YAML: {problem}", yaml_error_span(err, file), hint=hint)


def _nesting_refused(err: yaml.YAMLError) -> bool:
    """libyaml stops at 1,000 open collections: beyond the limits, not malformed text."""
    return "maximum nesting depth" in str(getattr(err, "problem", None) or "")


def compose_yaml(text: str, loader: type | None = None) -> yaml.Node | None:
    """``yaml.compose`` without its recursion, aliases or slow path (limits: RAC009).

    libyaml's event parser (when installed) reads megabytes in a fraction of a second and
    keeps its own stack; the nodes are built here, iteratively, counting the depth.  PyYAML's
    own parser (``loader=yaml.SafeLoader``) is iterative too: only its composer recurses.
    """
    try:
        return _compose_events(text, loader or _YAML_LOADER)
    except yaml.YAMLError as err:
        if _nesting_refused(err):
            message = f"lists and mappings nest more than {MAX_DEPTH} deep"
            mark = getattr(err, "problem_mark", None) or yaml.Mark("", 0, 0, 0, None, 0)
            raise YamlLimit(message, mark) from None
        raise


def _compose_events(text: str, loader: type) -> yaml.Node | None:
    root: yaml.Node | None = None
    stack: list[tuple[Any, list[Any]]] = []  # open collections and their items
    documents = 0

    def add(node: yaml.Node) -> None:
        nonlocal root
        if stack:
            stack[-1][1].append(node)
        else:
            root = node

    if not text.isascii():
        try:
            text.encode("utf-8")
        except UnicodeEncodeError as err:  # a lone surrogate (from a command-line argument)
            line = text.count("\n", 0, err.start)
            column = err.start - (text.rfind("\n", 0, err.start) + 1)
            mark = yaml.Mark("", err.start, line, column, None, 0)
            raise YamlLimit("not UTF-8 text: a lone surrogate", mark) from None
    for event in yaml.parse(text, Loader=loader):
        start: Any = event.start_mark  # libyaml's marks or PyYAML's: the same fields
        end: Any = event.end_mark
        if isinstance(event, yaml.DocumentStartEvent):
            documents += 1
            if documents > 1:
                raise YamlLimit("a file holds one YAML document", event.start_mark)
        elif isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
            raise YamlLimit("YAML anchors and aliases are not accepted", event.start_mark)
        elif isinstance(event, yaml.ScalarEvent):
            add(yaml.ScalarNode("", event.value, start, end))
        elif isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            if len(stack) >= MAX_DEPTH:
                raise YamlLimit(
                    f"lists and mappings nest more than {MAX_DEPTH} deep", event.start_mark
                )
            kind = (
                yaml.SequenceNode
                if isinstance(event, yaml.SequenceStartEvent)
                else yaml.MappingNode
            )
            stack.append((kind("", [], start, end), []))
        elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            done, items = stack.pop()
            done.end_mark = end
            if isinstance(done, yaml.MappingNode):
                done.value = list(zip(items[0::2], items[1::2], strict=True))
            else:
                done.value = items
            add(done)
    return root


def composed_yaml(text: str, file: str) -> yaml.Node | None:
    """:func:`compose_yaml` of a file's text, its size checked first: RacError RAC009, located,
    beyond the YAML limits (size, nesting, anchors and aliases); ``yaml.YAMLError`` for a text
    that is not YAML, for the caller to report with its own code."""
    if len(text) > MAX_YAML_BYTES:
        message = f"the file is {len(text):,} characters long (at most {MAX_YAML_BYTES:,})"
        raise RacError([Diagnostic("RAC009", message, Span(file, 1, 1, 1, 2))])
    return _within_limits(text, file, None)


def _within_limits(text: str, file: str, loader: type | None) -> yaml.Node | None:
    try:
        return compose_yaml(text, loader)
    except YamlLimit as err:
        line, column = err.mark.line + 1, err.mark.column + 1
        where = Span(file, line, column, line, column + 1)
        hint = "flatten the document, expand its anchors (see 'Limits' in docs/language.md)"
        raise RacError([Diagnostic("RAC009", err.message, where, hint=hint)], text) from None


def _pure_yaml_limits(text: str, file: str) -> None:
    """The limits under PyYAML's own (iterative) parser, for a text libyaml refused: PyYAML's
    recursive composer and constructor may then read it to say what is wrong, and they must
    not meet a text deeper than the limits (libyaml and PyYAML do not refuse alike).  Raises
    PyYAML's ``yaml.YAMLError`` when the text is not YAML."""
    _within_limits(text, file, yaml.SafeLoader)


def check_yaml_limits(text: str, file: str) -> None:
    """RAC009 when ``text`` is beyond the YAML limits; a text that is not YAML at all passes,
    for the caller's own parser (PyYAML's, then safe from recursion) to say why."""
    try:
        composed_yaml(text, file)
    except yaml.YAMLError:
        with contextlib.suppress(yaml.YAMLError):
            _pure_yaml_limits(text, file)


def safe_yaml(text: str, file: str) -> Any:
    """``yaml.safe_load(text)`` within the YAML limits (RAC009 beyond them).

    For the YAML files read whole (observers.yaml, costs, tug configs): PyYAML's recursion
    and its aliases (a "billion laughs" file) are not to be trusted.  A text that passed the
    limits is loaded by libyaml's loader where installed (the same constructor, several
    times faster: seconds on a 10,000-node observers.yaml); one that is not YAML raises
    PyYAML's own ``yaml.YAMLError``, the message the callers print.
    """
    try:
        composed_yaml(text, file)
    except yaml.YAMLError:
        _pure_yaml_limits(text, file)  # PyYAML's own error, or RAC009 ...
        return yaml.safe_load(text)  # ... or a text PyYAML reads and libyaml did not
    return yaml.load(text, Loader=_YAML_LOADER)
