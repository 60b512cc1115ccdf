"""A fast path for :func:`rac.parse.parse_ram`: a hand-written scanner for valid models.

Lark's LALR parser is the definition of the language and the source of every syntax
error message, but its Python lexer costs about 20 µs a token, several seconds for a
10,000-node model.  This module reads the same grammar (``rac/grammar/ram.lark``) with
the same terminal regular expressions, state by state, as a recursive descent over the
text, and builds exactly the IR the Lark path builds: the same values, the same spans
(a declaration's span runs from its keyword to its last token, ``;`` included), the same
comments.

It is deliberately strict: whenever the input strays from what it can read with certainty
(a syntax error, a name spelled like a keyword, a keyword glued to a following word), it
raises :class:`Bail` and :func:`rac.parse.parse_ram` parses the text again with Lark, which
then either accepts it or reports the error in its own words.  So the fast path can make
compilation quicker but never changes what is accepted or what an error says.
"""

from __future__ import annotations

import re
from typing import Any

from lark import Token

from rac.errors import Span
from rac.ir import (
    FieldRef,
    Hardware,
    Interval,
    Limits,
    Model,
    Name,
    Node,
    Publication,
    Related,
    Topic,
)

# The terminals of ram.lark, verbatim.
_NAME = re.compile(r"[A-Za-z_~\/][A-Za-z0-9_~\/\-]*")
_FIELD_REF = re.compile(
    r"[A-Za-z_~\/][A-Za-z0-9_~\/\-]*\.[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*"
)
_MSG_TYPE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\/[A-Za-z_][A-Za-z0-9_]*)+")
_FIELD = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
_NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?")
_INT = re.compile(r"\d+")
_WS = re.compile(r"[ \t\f\r\n]*")
_COMMENT = re.compile(r"#[^\n]*")
# Keywords are string terminals; reading a whole word and comparing it is stricter.
_WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_WORD_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_") - {""}
_SPACE_OR_HASH = frozenset(" \t\f\r\n#")

MEM_UNITS = {
    "B": 1,
    "kB": 1000,
    "KB": 1000,
    "MB": 1000**2,
    "GB": 1000**3,
    "KiB": 1024,
    "MiB": 1024**2,
    "GiB": 1024**3,
}

_KEYWORDS = frozenset(
    [
        "robot",
        "hardware",
        "switchable",
        "channel",
        "topic",
        "Hz",
        "window",
        "mismatch",
        "node",
        "drives",
        "subscribes",
        "publishes",
        "from",
        "limits",
        "cpu",
        "mem",
        "reports",
        "relate",
        "interval",
        "within",
    ]
)


class Bail(Exception):
    """The fast path cannot vouch for this input; parse it with Lark instead."""


class _Reader:
    __slots__ = ("comments", "last_col", "last_line", "line", "line_start", "path", "pos", "text")

    def __init__(self, text: str, path: str) -> None:
        self.text = text
        self.path = path
        self.pos = 0
        self.line = 1
        self.line_start = 0  # index of the first character of the current line
        self.last_line = 1  # end of the last token read (for rule spans)
        self.last_col = 1
        self.comments: list[Token] = []

    # scanning ----------------------------------------------------------------
    def skip(self) -> None:
        """Skip whitespace and comments, collecting the comments as Lark's callback does."""
        text = self.text
        while text[self.pos : self.pos + 1] in _SPACE_OR_HASH:
            if text[self.pos] == "#":
                start = self.pos
                stop = _COMMENT.match(text, start).end()  # type: ignore[union-attr]
                column = start - self.line_start + 1
                self.comments.append(
                    Token(
                        "COMMENT",
                        text[start:stop],
                        start_pos=start,
                        line=self.line,
                        column=column,
                        end_line=self.line,
                        end_column=column + stop - start,
                        end_pos=stop,
                    )
                )
                self.pos = stop
                continue
            end = _WS.match(text, self.pos).end()  # type: ignore[union-attr]
            newlines = text.count("\n", self.pos, end)
            if newlines:
                self.line += newlines
                self.line_start = text.rindex("\n", self.pos, end) + 1
            self.pos = end

    def at_end(self) -> bool:
        return self.pos >= len(self.text)

    def peek_char(self) -> str:
        return self.text[self.pos : self.pos + 1]

    def peek_word(self) -> str | None:
        m = _WORD.match(self.text, self.pos)
        return m.group() if m else None

    def _take(self, end: int) -> None:
        """Consume text up to ``end`` (one token, no newline)."""
        self.last_line = self.line
        self.last_col = end - self.line_start + 1
        self.pos = end

    def regex(self, pattern: re.Pattern[str]) -> str:
        start = self.pos
        m = pattern.match(self.text, start)
        if m is None or m.end() == start:
            raise Bail
        self._take(m.end())
        return m.group()

    def spanned(self, pattern: re.Pattern[str]) -> tuple[str, Span]:
        """A token and its span."""
        start = self.pos
        column = start - self.line_start + 1
        text = self.regex(pattern)
        return text, Span(self.path, self.line, column, self.line, self.last_col)

    def name(self) -> Name:
        value, span = self.spanned(_NAME)
        if value in _KEYWORDS:
            raise Bail
        return Name(value, span)

    def keyword(self, word: str) -> tuple[int, int]:
        """Consume the whole word ``word`` and return its start (line, column)."""
        text, pos = self.text, self.pos
        after = pos + len(word)
        if not text.startswith(word, pos) or text[after : after + 1] in _WORD_CHARS:
            raise Bail
        start = (self.line, pos - self.line_start + 1)
        self._take(after)
        return start

    def char(self, ch: str) -> None:
        if not self.text.startswith(ch, self.pos):
            raise Bail
        self._take(self.pos + len(ch))

    def optional_semicolon(self) -> None:
        self.skip()
        if self.peek_char() == ";":
            self.char(";")

    def span_from(self, start: tuple[int, int]) -> Span:
        return Span(self.path, start[0], start[1], self.last_line, self.last_col)

    def name_list(self) -> tuple[Name, ...]:
        names = [self.name()]
        while True:
            self.skip()
            if self.peek_char() != ",":
                return tuple(names)
            self.char(",")
            self.skip()
            names.append(self.name())

    def number(self) -> float:
        return float(self.regex(_NUMBER))

    def integer(self) -> int:
        return int(self.regex(_INT))

    # declarations ------------------------------------------------------------
    def model(self) -> tuple[Model, list[Token]]:
        self.skip()
        self.keyword("robot")
        self.skip()
        header = self.name()
        self.optional_semicolon()
        hardware: list[Hardware] = []
        topics: list[Topic] = []
        nodes: list[Node] = []
        related: list[Related] = []
        intervals: list[Interval] = []
        while True:
            self.skip()
            if self.at_end():
                break
            word = self.peek_word()
            if word == "hardware":
                hardware.append(self.hardware())
            elif word == "topic":
                topics.append(self.topic())
            elif word == "node":
                nodes.append(self.node())
            elif word == "relate":
                related.append(self.relate())
            elif word == "interval":
                intervals.append(self.interval())
            else:
                raise Bail
        model = Model(
            name=header,
            hardware=tuple(hardware),
            topics=tuple(topics),
            nodes=tuple(nodes),
            related=tuple(related),
            intervals=tuple(intervals),
            path=self.path,
        )
        return model, self.comments

    def hardware(self) -> Hardware:
        start = self.keyword("hardware")
        self.skip()
        name = self.name()
        switchable = False
        channel: int | None = None
        while True:
            self.skip()
            word = self.peek_word()
            if word == "switchable":
                self.keyword(word)
                switchable = True
            elif word == "channel":
                self.keyword(word)
                self.skip()
                channel = self.integer()
            else:
                break
        if self.peek_char() == ";":
            self.char(";")
        return Hardware(name, switchable=switchable, channel=channel, span=self.span_from(start))

    def topic(self) -> Topic:
        start = self.keyword("topic")
        self.skip()
        name = self.name()
        self.skip()
        msg_type: str | None = None
        if self.peek_char() == ":":
            self.char(":")
            self.skip()
            msg_type = self.regex(_MSG_TYPE)
            self.skip()
        fields: list[Name] = []
        if self.peek_char() == "{":
            self.char("{")
            self.skip()
            if self.peek_char() != "}":
                while True:
                    value, span = self.spanned(_FIELD)
                    fields.append(Name(value, span))
                    self.skip()
                    if self.peek_char() == ",":
                        self.char(",")
                        self.skip()
                        if self.peek_char() == "}":
                            break
                    elif self.peek_char() == "}":
                        break
                    else:
                        raise Bail
            self.char("}")
            self.skip()
        rate: float | None = None
        options: dict[str, Any] = {}
        if self.peek_char() == "@":
            self.char("@")
            self.skip()
            rate = self.number()
            self.skip()
            self.keyword("Hz")
            while True:
                self.skip()
                if self.text.startswith("+-", self.pos) or self.peek_char() == "±":
                    self.char("±" if self.peek_char() == "±" else "+-")
                    self.skip()
                    options["tolerance"] = self.number()
                    self.skip()
                    self.keyword("Hz")
                    continue
                word = self.peek_word()
                if word == "window":
                    self.keyword(word)
                    self.skip()
                    length = self.number()
                    self.skip()
                    unit = self.peek_word()
                    if unit not in ("s", "ms"):
                        raise Bail
                    self.keyword(unit)
                    options["window"] = length / (1000.0 if unit == "ms" else 1.0)
                elif word == "mismatch":
                    self.keyword(word)
                    self.skip()
                    options["mismatch"] = self.integer()
                else:
                    break
        if self.peek_char() == ";":
            self.char(";")
        return Topic(
            name,
            msg_type=msg_type,
            fields=tuple(fields),
            rate_hz=rate,
            rate_tolerance_hz=options.get("tolerance"),
            window_s=options.get("window"),
            mismatch_threshold=options.get("mismatch"),
            span=self.span_from(start),
        )

    def node(self) -> Node:
        start = self.keyword("node")
        self.skip()
        name = self.name()
        self.skip()
        drives: tuple[Name, ...] = ()
        if self.peek_word() == "drives":
            self.keyword("drives")
            self.skip()
            drives = self.name_list()
        subscribes: list[Name] = []
        publishes: list[Publication] = []
        diagnostics: list[Name] = []
        limits = Limits()
        if self.peek_char() == "{":
            self.char("{")
            while True:
                self.skip()
                if self.peek_char() == "}":
                    self.char("}")
                    break
                word = self.peek_word()
                if word == "subscribes":
                    self.keyword(word)
                    self.skip()
                    subscribes.extend(self.name_list())
                elif word == "reports":
                    self.keyword(word)
                    self.skip()
                    diagnostics.extend(self.name_list())
                elif word == "publishes":
                    self.keyword(word)
                    self.skip()
                    first = self.name()
                    self.skip()
                    if self.peek_word() == "from":
                        self.keyword("from")
                        self.skip()
                        publishes.append(Publication(first, self.name_list()))
                    else:
                        publishes.append(Publication(first))
                        while self.peek_char() == ",":
                            self.char(",")
                            self.skip()
                            publishes.append(Publication(self.name()))
                            self.skip()
                elif word == "limits":
                    limits_start = self.keyword(word)
                    cpu: float | None = None
                    mem: int | None = None
                    while True:
                        self.skip()
                        kind = self.peek_word()
                        if kind == "cpu":
                            self.keyword(kind)
                            self.skip()
                            value = self.number()
                            self.skip()
                            self.char("%")
                            cpu = value if cpu is None else cpu
                        elif kind == "mem":
                            self.keyword(kind)
                            self.skip()
                            value = self.number()
                            self.skip()
                            unit = self.peek_word()
                            if unit not in MEM_UNITS:
                                raise Bail
                            self.keyword(unit)
                            amount = round(value * MEM_UNITS[unit])
                            mem = amount if mem is None else mem
                        else:
                            raise Bail
                        self.skip()
                        if self.peek_char() != ",":
                            break
                        self.char(",")
                    if self.peek_char() == ";":
                        self.char(";")
                    stmt = Limits(cpu=cpu, mem=mem, span=self.span_from(limits_start))
                    limits = Limits(
                        cpu=stmt.cpu if stmt.cpu is not None else limits.cpu,
                        mem=stmt.mem if stmt.mem is not None else limits.mem,
                        span=stmt.span,
                    )
                    continue
                else:
                    raise Bail
                self.skip()
                if self.peek_char() == ";":
                    self.char(";")
        self.optional_semicolon()
        return Node(
            name,
            drives=drives,
            subscribes=tuple(subscribes),
            publishes=tuple(publishes),
            limits=limits,
            diagnostics=tuple(diagnostics),
            span=self.span_from(start),
        )

    def field_ref(self) -> FieldRef:
        text, span = self.spanned(_FIELD_REF)
        return FieldRef.parse(text, span)

    def _pair(self, keyword: str) -> tuple[tuple[int, int], FieldRef, FieldRef]:
        start = self.keyword(keyword)
        self.skip()
        a = self.field_ref()
        self.skip()
        self.char("~")
        self.skip()
        b = self.field_ref()
        return start, a, b

    def relate(self) -> Related:
        start, a, b = self._pair("relate")
        self.optional_semicolon()
        return Related(a, b, span=self.span_from(start))

    def interval(self) -> Interval:
        start, a, b = self._pair("interval")
        self.skip()
        self.keyword("within")
        self.skip()
        diff = self.number()
        self.optional_semicolon()
        return Interval(a, b, diff, span=self.span_from(start))


def fast_parse(text: str, path: str) -> tuple[Model, list[Token]]:
    """The model (comments not yet attached) and its comment tokens; :class:`Bail` if unsure."""
    return _Reader(text, path).model()
