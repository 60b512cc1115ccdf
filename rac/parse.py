"""Parse ``.ram`` text into the IR: Lark LALR with positions, then a Transformer.

Parse failures become named diagnostics that say, in words, what was expected.
"""

from __future__ import annotations

import bisect
import functools
import math
import re
from dataclasses import replace
from importlib import resources
from typing import Any

from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import (
    UnexpectedCharacters,
    UnexpectedEOF,
    UnexpectedInput,
    UnexpectedToken,
    VisitError,
)
from lark.tree import Meta

from rac.errors import Diagnostic, RacError, Span, did_you_mean
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

# What each terminal means to a user, for "expected ..." messages.
_TERMINAL_WORDS = {
    "NAME": "a name",
    "FIELD_REF": "a field reference such as /imu_data.yaw",
    "MSG_TYPE": "a message type such as nav_msgs/Odometry",
    "FIELD": "a field name",
    "NUMBER": "a number",
    "INT": "a whole number",
    "PLUS_MINUS": "'+-'",
    "TIME_UNIT": "a time unit (s, ms)",
    "MEM_UNIT": "a memory unit (B, kB, MB, GB, KiB, MiB, GiB)",
    "LBRACE": "'{'",
    "RBRACE": "'}'",
    "COMMA": "','",
    "SEMICOLON": "';'",
    "COLON": "':'",
    "AT": "'@'",
    "PERCENT": "'%'",
    "TILDE": "'~'",
    "I": "'I(' (an integrated field)",
    "LPAR": "'('",
    "RPAR": "')'",
    "$END": "the end of the file",
}


def _span(file: str, item: Token | Meta) -> Span:
    assert item.line is not None and item.column is not None
    end_line = item.end_line if item.end_line is not None else item.line
    end_col = item.end_column if item.end_column is not None else item.column + 1
    return Span(file, item.line, item.column, end_line, end_col)


def _words(expected: set[str]) -> str:
    names = sorted({_TERMINAL_WORDS.get(t, _keyword(t)) for t in expected})
    if len(names) == 1:
        return names[0]
    return ", ".join(names[:-1]) + " or " + names[-1]


def _keyword(terminal: str) -> str:
    """A keyword terminal as the user writes it: ``HZ`` -> ``'Hz'``, ``SEMICOLON`` -> ``';'``."""
    return f"'{_literals().get(terminal, terminal.lower())}'"


@functools.cache
def _literals() -> dict[str, str]:
    """Terminal name -> its literal text, for the grammar's string terminals."""
    return {
        t.name: t.pattern.value for t in _commented_parser().terminals if t.pattern.type == "str"
    }


def _keyword_hint(token: Token, expected: set[str]) -> str | None:
    """Did-you-mean for a misspelt keyword (``subscribe`` for ``subscribes``)."""
    keywords = [_literals()[t] for t in expected if t in _literals()]
    return did_you_mean(str(token), [k for k in keywords if k.isalpha()])


def _parse_error(err: UnexpectedInput, path: str, text: str) -> Diagnostic:
    line, column = max(err.line, 1), max(err.column, 1)
    if isinstance(err, UnexpectedToken) and err.token.type == "$END":
        line, column = _end_position(text)
        span = Span(path, line, column, line, column + 1)
        opened = _open_block(text, len(text)) if "RBRACE" in err.expected else None
        if opened:
            message = f"unexpected end of file: {opened} is missing its '}}'"
            return Diagnostic("RAC002", message, span, hint=f"expected {_words(err.expected)}")
        return Diagnostic(
            "RAC002", f"unexpected end of file; expected {_words(err.expected)}", span
        )
    if isinstance(err, UnexpectedToken):
        special = _special_token_error(err, path, text)
        if special is not None:
            return special
        token = err.token
        span = _span(path, token)
        message = f"unexpected '{token}'; expected {_words(err.expected)}"
        return Diagnostic("RAC001", message, span, hint=_keyword_hint(token, err.expected))
    if isinstance(err, UnexpectedCharacters):
        span = Span(path, line, column, line, column + 1)
        pos = err.pos_in_stream
        char = text[pos] if pos is not None and pos < len(text) else "?"
        allowed = err.allowed or set()
        hint = f"expected {_words(allowed)}" if allowed else None
        return Diagnostic("RAC003", f"unexpected character {char!r}", span, hint=hint)
    if isinstance(err, UnexpectedEOF):
        line, column = _end_position(text)
        span = Span(path, line, column, line, column + 1)
        return Diagnostic(
            "RAC002", f"unexpected end of file; expected {_words(set(err.expected))}", span
        )
    span = Span(path, line, column, line, column + 1)
    return Diagnostic("RAC001", "syntax error", span)


_DECLARATIONS = ("hardware", "topic", "node", "relate", "interval")
_UNIT_TERMINALS = {"MEM_UNIT": "a memory unit", "HZ": "'Hz'", "TIME_UNIT": "a time unit"}
_NUMBER_BEFORE = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?\s*$")
_BLOCK_HEAD = re.compile(r"(?:^|(?<=[\s;}]))(node|topic)\s+([A-Za-z_~/][A-Za-z0-9_~/\-]*)")


# The units each unit terminal of the grammar accepts (rac/grammar/ram.lark).
_UNITS = {
    "MEM_UNIT": ("GiB", "MiB", "KiB", "GB", "MB", "kB", "KB", "B"),
    "HZ": ("Hz",),
    "TIME_UNIT": ("ms", "s"),
}


def _misspelt_unit(word: str, terminals: list[str]) -> str | None:
    """'did you mean ...?' when ``word`` is an expected unit in another case (`Gb`, `hz`)."""
    for terminal in terminals:
        for unit in _UNITS.get(terminal, ()):
            if word.lower() == unit.lower() and word != unit:
                return f"did you mean '{unit}'?"
    return None


def _special_token_error(err: UnexpectedToken, path: str, text: str) -> Diagnostic | None:
    """The syntax errors that read better in words than as 'unexpected X; expected Y'."""
    token = err.token
    start = token.start_pos if token.start_pos is not None else 0
    before = text[:start]
    # A number without its unit: the parser only notices at the next token, maybe lines on.
    units = [t for t in err.expected if t in _UNIT_TERMINALS]
    number = _NUMBER_BEFORE.search(before) if units else None
    if number is not None:
        value = number.group().strip()
        misspelt = _misspelt_unit(str(token), units)
        if misspelt is not None:  # `1 Gb`, `10 hz`: the unit is there, in the wrong case
            message = f"unknown unit '{token}': expected {_words(set(err.expected))}"
            return Diagnostic("RAC001", message, _span(path, token), hint=misspelt)
        at = _span_of(path, text, number.start(), number.start() + len(value))
        message = f"the number {value} needs its unit: expected {_words(set(err.expected))}"
        return Diagnostic(
            "RAC001", message, at, hint=f"write e.g. '{value} {_unit_example(units)}'"
        )
    # `mismatch 2.5`: the whole number ends at the dot, and '.5' is read as the next number.
    if str(token).startswith(".") and before[-1:].isdigit():
        digits = len(before) - len(before.rstrip("0123456789"))
        first = start - digits
        keyword = before[:first].split()[-1:] or ["this"]
        whole = text[first : token.end_pos]
        at = _span_of(path, text, first, first + len(whole))
        message = f"'{keyword[0]}' takes a whole number, not {whole}"
        return Diagnostic("RAC001", message, at)
    # A block left open: the next declaration is where the parser notices.
    if "RBRACE" in err.expected and str(token) in _DECLARATIONS:
        opened = _open_block(text, start)
        if opened:
            message = f"{opened} is missing its '}}' before this {token}"
            return Diagnostic("RAC001", message, _span(path, token), hint="add '}' to close it")
    return None


def _unit_example(units: list[str]) -> str:
    return {"MEM_UNIT": "MB", "HZ": "Hz", "TIME_UNIT": "s"}[sorted(units)[0]]


def _span_of(path: str, text: str, start: int, end: int) -> Span:
    line = text.count("\n", 0, start) + 1
    column = start - (text.rfind("\n", 0, start) + 1) + 1
    return Span(path, line, column, line, column + max(1, end - start))


def _open_block(text: str, end: int) -> str | None:
    """The innermost node body or field list still open at ``end``: "node 'x' (line 3)"."""
    stack: list[int] = []
    for m in re.finditer(r"#[^\n]*|[{}]", text[:end]):
        if m.group() == "{":
            stack.append(m.start())
        elif m.group() == "}" and stack:
            stack.pop()
    if not stack:
        return None
    brace = stack[-1]
    heads = list(_BLOCK_HEAD.finditer(text, 0, brace))
    if not heads:
        return None
    head = heads[-1]
    line = text.count("\n", 0, head.start()) + 1
    what = "node" if head.group(1) == "node" else "the field list of topic"
    return f"{what} '{head.group(2)}' (line {line})"


def _end_position(text: str) -> tuple[int, int]:
    lines = text.rstrip().splitlines() or [""]
    return len(lines), len(lines[-1]) + 1


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
        raise RacError([_parse_error(err, path, text)], text) from None
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
    # so route comments through a module-level list swapped in for this call.
    _COMMENT_SINK.append(sink)
    try:
        return _commented_parser().parse(text)
    finally:
        _COMMENT_SINK.pop()


_COMMENT_SINK: list[list[Token]] = []


def _collect_comment(token: Token) -> Token:
    if _COMMENT_SINK:
        _COMMENT_SINK[-1].append(token)
    return token


@functools.cache
def _commented_parser() -> Lark:
    grammar = resources.files("rac.grammar").joinpath("ram.lark").read_text(encoding="utf-8")
    return Lark(
        grammar,
        parser="lalr",
        propagate_positions=True,
        maybe_placeholders=True,
        lexer_callbacks={"COMMENT": _collect_comment},
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
