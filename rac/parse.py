"""Parse ``.ram`` text into the IR: Lark LALR with positions, then a Transformer.

Parse failures become named diagnostics that say, in words, what was expected.
"""

from __future__ import annotations

import bisect
import functools
import math
from collections.abc import Iterator
from dataclasses import replace
from importlib import resources
from typing import Any

from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import UnexpectedInput, VisitError
from lark.tree import Meta

from rac.errors import Diagnostic, RacError, Span
from rac.fastparse import MEM_UNITS, Bail, fast_parse
from rac.ir import (
    Container,
    FieldRef,
    Hardware,
    Interval,
    Limits,
    Machine,
    Model,
    Name,
    Node,
    Publication,
    Related,
    Topic,
)
from rac.limits import number_text_problem, ram_number_problems
from rac.perf import paused_gc
from rac.syntax_errors import (
    WORD_CHARACTERS,
    WORD_TERMINALS,
    glued_keyword_error,
    span_of_token,
    syntax_error,
)


def _span(file: str, item: Token | Meta) -> Span:
    return span_of_token(file, item)


@functools.cache
def _literals() -> dict[str, str]:
    """Terminal name -> its literal text, for the grammar's string terminals."""
    return {
        t.name: t.pattern.value for t in _commented_parser().terminals if t.pattern.type == "str"
    }


def parse_ram(text: str, path: str = "<string>") -> Model:
    """Parse a ``.ram`` source into a :class:`Model` (not yet validated)."""
    # Numbers out of range are reported before parsing: the parsers convert them.
    out_of_range = ram_number_problems(text, path)
    if out_of_range:
        raise RacError(out_of_range, text)
    with paused_gc():
        try:
            # The recursive-descent parser of valid models is about five times faster;
            # Lark stays the definition of the language and of every syntax error.
            model, comments = fast_parse(text, path)
        except (Bail, OverflowError, ValueError):  # a number int() or round() refuses: Lark says
            model, comments = _parse_with_lark(text, path)
        model = _attach_comments(model, comments)
        return replace(model, source=text)


def _parse_with_lark(text: str, path: str) -> tuple[Model, list[Token]]:
    comments: list[Token] = []
    try:
        tree = _parse_with_comments(text, comments)
    except UnexpectedInput as err:
        raise RacError([syntax_error(err, path, text, _literals())], text) from None
    except _GluedKeyword as glued:
        expected = _expected_before(text, glued.token)
        diagnostic = glued_keyword_error(glued.token, path, text, expected, _literals())
        raise RacError([diagnostic], text) from None
    try:
        model = _Lower(path).transform(tree)
    except VisitError as err:
        if not isinstance(err.orig_exc, _OutOfRange):
            raise
        bad = err.orig_exc
        message = f"number {str(bad.token)[:20]}: {bad.problem}"
        raise RacError([Diagnostic("RAC007", message, _span(path, bad.token))], text) from None
    assert isinstance(model, Model)
    return model, comments


def _parse_with_comments(text: str, sink: list[Token]) -> Tree[Token]:
    # A fresh parser per call would be slow; lexer callbacks are bound per parser,
    # so route comments (and the text, for the keyword check) through a module-level
    # list swapped in for this call.
    _SOURCES.append((text, sink))
    try:
        return _commented_parser().parse(text)
    finally:
        _SOURCES.pop()


# (text, comments) of each parse under way, innermost last.
_SOURCES: list[tuple[str, list[Token]]] = []


def _collect_comment(token: Token) -> Token:
    if _SOURCES:
        _SOURCES[-1][1].append(token)
    return token


class _GluedKeyword(Exception):
    """A keyword token that is the front of a longer word (``mem`` of ``memory``)."""

    def __init__(self, token: Token) -> None:
        super().__init__(str(token))
        self.token = token


class _WholeWords:
    """Keywords are whole words.  Lark's contextual lexer tries only the terminals a state
    accepts, so where no name may come it would read ``memory`` as ``mem`` then ``ory``, and
    ``publishes /a fromage`` as ``from age``; the fast parser reads words whole.  A
    post-lexer (Lark's ``postlex``) that stops at a keyword glued to the letters after it."""

    always_accept: tuple[str, ...] = ()

    def process(self, stream: Iterator[Token]) -> Iterator[Token]:
        keywords = _keyword_terminals()
        text = _SOURCES[-1][0] if _SOURCES else ""
        for token in stream:
            end = token.end_pos
            glued = end is not None and end < len(text) and text[end] in WORD_CHARACTERS
            if glued and token.type in keywords:
                raise _GluedKeyword(token)
            yield token


def _expected_before(text: str, token: Token) -> set[str]:
    """The terminals the parser accepts where ``token`` starts."""
    _SOURCES.append((text, []))
    try:
        interactive = _commented_parser().parse_interactive(text[: token.start_pos])
        interactive.exhaust_lexer()
        return set(interactive.accepts())  # type: ignore[no-untyped-call]  # Lark's
    finally:
        _SOURCES.pop()


@functools.cache
def _keyword_terminals() -> frozenset[str]:
    """The terminals that are words: the alphabetic string keywords and the unit terminals."""
    words = [
        t.name
        for t in _commented_parser().terminals
        if t.pattern.type == "str" and t.pattern.value[:1].isalpha()
    ]
    return frozenset([*words, *WORD_TERMINALS])


@functools.cache
def _commented_parser() -> Lark:
    grammar = resources.files("rac.grammar").joinpath("ram.lark").read_text(encoding="utf-8")
    return Lark(
        grammar,
        parser="lalr",
        propagate_positions=True,
        maybe_placeholders=True,
        lexer_callbacks={"COMMENT": _collect_comment},
        postlex=_WholeWords(),
    )


class _OutOfRange(Exception):
    """A number the pre-scan could not see (glued to a keyword: ``mem1e400``)."""

    def __init__(self, token: Token, problem: str) -> None:
        super().__init__(problem)
        self.token, self.problem = token, problem


def _number(token: Token) -> float:
    return float(token)  # inf when out of range: the validation pass reports it (RAC007)


def _integer(token: Token) -> int:
    problem = number_text_problem(str(token))
    if problem is not None:  # int() refuses thousands of digits
        raise _OutOfRange(token, problem)
    return int(token)


def _bytes(token: Token, unit: Token) -> int:
    value = _number(token) * MEM_UNITS[str(unit)]
    if not math.isfinite(value):  # round() refuses infinities
        raise _OutOfRange(token, number_text_problem(str(token)) or "not a finite number")
    return round(value)


@v_args(meta=True)
class _Lower(Transformer[Token, Any]):
    """Lower the parse tree to IR dataclasses, keeping a span on every node."""

    def __init__(self, path: str) -> None:
        super().__init__()
        self.path = path

    def _name(self, token: Token) -> Name:
        return Name(str(token), _span(self.path, token))

    def start(self, meta: Meta, children: list[Any]) -> Model:
        header, *decls = children
        return Model(
            name=header,
            hardware=tuple(d for d in decls if isinstance(d, Hardware)),
            topics=tuple(d for d in decls if isinstance(d, Topic)),
            nodes=tuple(d for d in decls if isinstance(d, Node)),
            related=tuple(d for d in decls if isinstance(d, Related)),
            intervals=tuple(d for d in decls if isinstance(d, Interval)),
            machines=tuple(d for d in decls if isinstance(d, Machine)),
            path=self.path,
        )

    # machines ------------------------------------------------------------
    def machine(self, meta: Meta, children: list[Any]) -> Machine:
        name, address = children
        return Machine(
            self._name(name),
            address=str(address) if address is not None else None,
            span=_span(self.path, meta),
        )

    def header(self, meta: Meta, children: list[Token]) -> Name:
        return self._name(children[0])

    # hardware ------------------------------------------------------------
    def hardware(self, meta: Meta, children: list[Any]) -> Hardware:
        name, *options = children
        switchable = any(o == ("switchable", None) for o in options)
        channels = [o[1] for o in options if o[0] == "channel"]
        return Hardware(
            self._name(name),
            switchable=switchable,
            channel=channels[-1] if channels else None,
            span=_span(self.path, meta),
        )

    def switchable(self, meta: Meta, children: list[Any]) -> tuple[str, None]:
        return ("switchable", None)

    def channel(self, meta: Meta, children: list[Token]) -> tuple[str, int]:
        return ("channel", _integer(children[0]))

    # topics --------------------------------------------------------------
    def topic(self, meta: Meta, children: list[Any]) -> Topic:
        name, msg_type, fields, rate = children
        hz, rate_span, options = rate if rate is not None else (None, None, {})
        values = {kind: value for kind, (value, _) in options.items()}
        spans = {kind: span for kind, (_, span) in options.items()}
        return Topic(
            self._name(name),
            msg_type=msg_type,
            fields=tuple(fields or ()),
            rate_hz=hz,
            rate_tolerance_hz=values.get("tolerance"),
            window_s=values.get("window"),
            mismatch_threshold=values.get("mismatch"),
            span=_span(self.path, meta),
            rate_span=rate_span,
            tolerance_span=spans.get("tolerance"),
            window_span=spans.get("window"),
            mismatch_span=spans.get("mismatch"),
        )

    def msg_type(self, meta: Meta, children: list[Token]) -> str:
        return str(children[0])

    def field_block(self, meta: Meta, children: list[Token | None]) -> tuple[Name, ...]:
        return tuple(self._name(t) for t in children if t is not None)

    def rate(
        self, meta: Meta, children: list[Any]
    ) -> tuple[float, Span, dict[str, tuple[float, Span]]]:
        """The rate, its span and each option's value and span (the last of a repeated one)."""
        (hz, span), *options = children
        return hz, span, {kind: (value, at) for kind, value, at in options}

    def frequency(self, meta: Meta, children: list[Token]) -> tuple[float, Span]:
        return _number(children[0]), _span(self.path, meta)

    def tolerance(self, meta: Meta, children: list[Token]) -> tuple[str, float, Span]:
        return ("tolerance", _number(children[1]), _span(self.path, meta))

    def window(self, meta: Meta, children: list[Token]) -> tuple[str, float, Span]:
        value, unit = children
        seconds = _number(value) / (1000.0 if unit == "ms" else 1.0)
        return ("window", seconds, _span(self.path, meta))

    def mismatch(self, meta: Meta, children: list[Token]) -> tuple[str, int, Span]:
        return ("mismatch", _integer(children[0]), _span(self.path, meta))

    # nodes ---------------------------------------------------------------
    def node(self, meta: Meta, children: list[Any]) -> Node:
        name, drives, machine, container, body = children
        stmts: list[tuple[str, Any]] = list(body or ())
        subscribes = tuple(n for kind, v in stmts if kind == "subscribes" for n in v)
        publishes = tuple(p for kind, v in stmts if kind == "publishes" for p in v)
        diagnostics = tuple(n for kind, v in stmts if kind == "reports" for n in v)
        limits = Limits()
        for kind, value in stmts:
            if kind == "limits":
                limits = Limits(
                    cpu=value.cpu if value.cpu is not None else limits.cpu,
                    mem=value.mem if value.mem is not None else limits.mem,
                    span=value.span,
                )
        return Node(
            self._name(name),
            drives=tuple(drives or ()),
            subscribes=subscribes,
            publishes=publishes,
            limits=limits,
            diagnostics=diagnostics,
            machine=machine,
            container=container,
            span=_span(self.path, meta),
        )

    def on_machine(self, meta: Meta, children: list[Token]) -> Name:
        return self._name(children[0])

    def container(self, meta: Meta, children: list[Token]) -> Container:
        name, runtime = children
        return Container(self._name(name), str(runtime))

    def drives(self, meta: Meta, children: list[tuple[Name, ...]]) -> tuple[Name, ...]:
        return children[0]

    def node_body(self, meta: Meta, children: list[Any]) -> tuple[Any, ...]:
        return tuple(children)

    def name_list(self, meta: Meta, children: list[Token]) -> tuple[Name, ...]:
        return tuple(self._name(t) for t in children)

    def subscribes(self, meta: Meta, children: list[Any]) -> tuple[str, Any]:
        return ("subscribes", children[0])

    def publishes(self, meta: Meta, children: list[Any]) -> tuple[str, Any]:
        return ("publishes", tuple(Publication(n) for n in children[0]))

    def publishes_from(self, meta: Meta, children: list[Any]) -> tuple[str, Any]:
        topic, inputs = children
        return ("publishes", (Publication(self._name(topic), inputs),))

    def reports(self, meta: Meta, children: list[Any]) -> tuple[str, Any]:
        return ("reports", children[0])

    def limits(self, meta: Meta, children: list[Any]) -> tuple[str, Any]:
        cpu = next((v for k, v in children if k == "cpu"), None)
        mem = next((v for k, v in children if k == "mem"), None)
        return ("limits", Limits(cpu=cpu, mem=mem, span=_span(self.path, meta)))

    def cpu_limit(self, meta: Meta, children: list[Token]) -> tuple[str, float]:
        return ("cpu", _number(children[0]))

    def mem_limit(self, meta: Meta, children: list[Token]) -> tuple[str, int]:
        value, unit = children
        return ("mem", _bytes(value, unit))

    # relations -----------------------------------------------------------
    def _field_ref(self, side: Token | FieldRef) -> FieldRef:
        if isinstance(side, FieldRef):
            return side
        return FieldRef.parse(str(side), _span(self.path, side))

    def integral(self, meta: Meta, children: list[Token]) -> FieldRef:
        topic, _, path = str(children[0]).partition(".")
        return FieldRef(topic, path, _span(self.path, meta), integrated=True)

    def relate(self, meta: Meta, children: list[Token | FieldRef]) -> Related:
        a, b = children
        return Related(self._field_ref(a), self._field_ref(b), span=_span(self.path, meta))

    def interval(self, meta: Meta, children: list[Token | FieldRef]) -> Interval:
        a, b, diff = children
        assert isinstance(diff, Token)
        return Interval(
            self._field_ref(a), self._field_ref(b), _number(diff), span=_span(self.path, meta)
        )


def _attach_comments(model: Model, comments: list[Token]) -> Model:
    """Hang each comment on the declaration it precedes (or sits inside)."""
    if not comments:
        return model
    decls: list[Any] = sorted(
        [
            *model.machines,
            *model.hardware,
            *model.topics,
            *model.nodes,
            *model.related,
            *model.intervals,
        ],
        key=lambda d: (d.span.line, d.span.column),
    )
    header_line = model.name.span.line if model.name.span else 1
    # Declarations do not overlap, so their last lines ascend with their first ones.
    end_lines = [d.span.end_line for d in decls]
    pending = sorted(comments, key=lambda t: (t.line or 0, t.column or 0))
    leading: dict[int, list[str]] = {}
    inner: dict[int, list[tuple[int, str]]] = {}
    head: list[str] = []
    tail: list[str] = []
    for token in pending:
        line = token.line or 0
        body = str(token)[1:].rstrip()
        owner = bisect.bisect_left(end_lines, line)
        if line < header_line:
            head.append(body)
        elif owner == len(decls):
            tail.append(body)
        elif isinstance(decls[owner], Node) and line > decls[owner].span.line:
            inner.setdefault(owner, []).append((line, body))
        else:
            leading.setdefault(owner, []).append(body)
    new = {
        id(decls[i]): replace(
            decls[i],
            comments=tuple(leading.get(i, ())),
            **({"body_comments": _anchor(decls[i], inner[i])} if i in inner else {}),
        )
        for i in sorted(leading.keys() | inner.keys())
    }

    def swap(items: tuple[Any, ...]) -> tuple[Any, ...]:
        return tuple(new.get(id(x), x) for x in items)

    return replace(
        model,
        hardware=swap(model.hardware),
        topics=swap(model.topics),
        nodes=swap(model.nodes),
        related=swap(model.related),
        intervals=swap(model.intervals),
        machines=swap(model.machines),
        comments=tuple(head),
        trailing_comments=tuple(tail),
    )


def _statement_lines(node: Node) -> list[tuple[int, int, str]]:
    """(line, column, anchor) of each statement of a node body, from the spans it left."""
    found: list[tuple[int, int, str]] = []

    def add(span: Span | None, anchor: str) -> None:
        if span is not None:
            found.append((span.line, span.column, anchor))

    if node.subscribes:
        add(node.subscribes[0].span, "subscribes")
    for pub in node.publishes:
        add(pub.topic.span, f"pub:{pub.topic.value}")
    add(node.limits.span, "limits")
    if node.diagnostics:
        add(node.diagnostics[0].span, "reports")
    return sorted(found)


def _anchor(node: Node, comments: list[tuple[int, str]]) -> tuple[tuple[str, str], ...]:
    """Each body comment with the first statement on or after its line (or "end")."""
    statements = _statement_lines(node)
    anchored = []
    for line, text in comments:
        anchor = next((a for at, _, a in statements if at >= line), "end")
        anchored.append((anchor, text))
    return tuple(anchored)
