"""The fast path of :func:`rac.parse.parse_ram`: a recursive-descent parser of valid models.

Lark's LALR parser is the definition of the language and the source of every syntax error
message, but its Python lexer and tree cost about 5 s for a 10,000-node model, where this
parser takes well under one (docs/performance.md, "Parsing").  It reads the grammar
(``rac/grammar/ram.lark``) rule by rule, one method per rule, over the tokens of
:mod:`rac.ram_lexer`, deciding each step on the current token alone: no backtracking and
nothing read twice.  It builds exactly the IR the Lark path builds (``rac.parse._Lower``):
the same values, the same spans (a rule's span runs from its first token to its last, a
declaration's ``;`` included) and the same comments.

It is deliberately strict: at the first token that is not what the grammar expects where
it stands (a syntax error, or a layout only Lark's contextual lexer reads, such as a keyword
glued to the next word), it raises :class:`Bail` and :func:`rac.parse.parse_ram` parses the
text again with Lark, which either accepts it or reports the error in its own words.  So
this parser makes compilation quicker but never changes what is accepted or what an error
says; ``tests/test_fastparse.py`` checks it against Lark on the example models, odd layouts,
mutants and random models.
"""

from __future__ import annotations

import re
import sys

from lark import Token

from rac.errors import Span
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
from rac.ram_lexer import (
    CONTAINER_RUNTIMES,
    END,
    MEM_UNIT_NAMES,
    TERMINALS,
    TIME_UNITS,
    Bail,
    Lexer,
)

__all__ = ["MEM_UNITS", "Bail", "fast_parse"]

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

# Words checked against a terminal the master pattern does not read on its own.
_MSG_TYPE = re.compile(TERMINALS["MSG_TYPE"])
_FIELD = re.compile(TERMINALS["FIELD"])
_INT = re.compile(TERMINALS["INT"])
_DECLARATIONS = ("hardware", "topic", "node", "relate", "interval", "machine")
_STATEMENTS = ("subscribes", "publishes", "limits", "reports")
_NO_LIMITS = Limits()
# A name's text is interned: a topic named in ten places is then one string, so the passes'
# many dict and set lookups by name find it by identity (and a large model takes less memory).
_intern = sys.intern


class _Parser:
    """One method per rule of ram.lark, each starting at the rule's first token."""

    __slots__ = ("lex", "path")

    def __init__(self, text: str, path: str) -> None:
        self.path = path
        self.lex = Lexer(text, path)

    # tokens ------------------------------------------------------------------------
    def keyword(self, word: str) -> tuple[int, int]:
        """Consume the keyword ``word``; return where it starts (line, column)."""
        lex = self.lex
        if lex.kind != "NAME" or lex.value != word:
            raise Bail
        start = (lex.line, lex.column)
        lex.advance()
        return start

    def punctuation(self, char: str) -> None:
        if self.lex.kind != char:
            raise Bail
        self.lex.advance()

    def optional_semicolon(self) -> None:
        if self.lex.kind == ";":
            self.lex.advance()

    def word(self, choices: tuple[str, ...]) -> str:
        """One of the literal ``choices`` of a string terminal (a unit, a runtime)."""
        lex = self.lex
        value = lex.value
        if lex.kind != "NAME" or value not in choices:
            raise Bail
        lex.advance()
        return value

    def matching(self, pattern: re.Pattern[str]) -> tuple[str, Span]:
        """A word that is wholly a ``pattern`` terminal, and its span."""
        lex = self.lex
        value = lex.value
        if lex.kind not in ("NAME", "FIELD_REF") or pattern.fullmatch(value) is None:
            raise Bail
        span = Span(self.path, lex.line, lex.column, lex.line, lex.column + len(value))
        lex.advance()
        return value, span

    def name(self) -> Name:
        lex = self.lex
        if lex.kind != "NAME":
            raise Bail
        value = lex.value
        name = Name(
            _intern(value), Span(self.path, lex.line, lex.column, lex.line, lex.column + len(value))
        )
        lex.advance()
        return name

    def name_list(self) -> tuple[Name, ...]:
        names = [self.name()]
        while self.lex.kind == ",":
            self.lex.advance()
            names.append(self.name())
        return tuple(names)

    def number(self) -> float:
        lex = self.lex
        if lex.kind != "NUMBER":
            raise Bail
        value = float(lex.value)  # inf when out of range, as Lark's path
        lex.advance()
        return value

    def integer(self) -> int:
        lex = self.lex
        if lex.kind != "NUMBER" or _INT.fullmatch(lex.value) is None:
            raise Bail
        value = int(lex.value)  # ValueError beyond int()'s digits: parse_ram asks Lark
        lex.advance()
        return value

    def span_from(self, start: tuple[int, int]) -> Span:
        """From ``start`` to the end of the token consumed last."""
        return Span(self.path, start[0], start[1], self.lex.end_line, self.lex.end_column)

    def here(self) -> tuple[int, int]:
        return (self.lex.line, self.lex.column)

    # start: header decl* -------------------------------------------------------------
    def model(self) -> Model:
        self.keyword("robot")
        header = self.name()
        self.optional_semicolon()
        found: dict[str, list[object]] = {kind: [] for kind in _DECLARATIONS}
        readers = {
            "hardware": self.hardware,
            "topic": self.topic,
            "node": self.node,
            "relate": self.relate,
            "interval": self.interval,
            "machine": self.machine,
        }
        lex = self.lex
        while lex.kind != END:
            if lex.kind != "NAME" or lex.value not in readers:
                raise Bail
            found[lex.value].append(readers[lex.value]())
        return Model(
            name=header,
            hardware=tuple(found["hardware"]),  # type: ignore[arg-type]
            topics=tuple(found["topic"]),  # type: ignore[arg-type]
            nodes=tuple(found["node"]),  # type: ignore[arg-type]
            related=tuple(found["relate"]),  # type: ignore[arg-type]
            intervals=tuple(found["interval"]),  # type: ignore[arg-type]
            machines=tuple(found["machine"]),  # type: ignore[arg-type]
            path=self.path,
        )

    # machine: "machine" NAME ["address" ADDRESS] ";"? --------------------------------
    def machine(self) -> Machine:
        start = self.keyword("machine")
        name = self.name()
        address: str | None = None
        lex = self.lex
        if lex.kind == "NAME" and lex.value == "address":
            lex.advance()
            lex.read_as("ADDRESS")
            address = lex.value
            lex.advance()
        self.optional_semicolon()
        return Machine(name, address=address, span=self.span_from(start))

    # hardware: "hardware" NAME hw_option* ";"? ----------------------------------------
    def hardware(self) -> Hardware:
        start = self.keyword("hardware")
        name = self.name()
        switchable = False
        channel: int | None = None
        lex = self.lex
        while lex.kind == "NAME":
            if lex.value == "switchable":
                lex.advance()
                switchable = True
            elif lex.value == "channel":
                lex.advance()
                channel = self.integer()
            else:
                break
        self.optional_semicolon()
        return Hardware(name, switchable=switchable, channel=channel, span=self.span_from(start))

    # topic: "topic" NAME [msg_type] [field_block] [rate] ";"? -------------------------
    def topic(self) -> Topic:
        start = self.keyword("topic")
        name = self.name()
        lex = self.lex
        msg_type: str | None = None
        if lex.kind == ":":
            lex.advance()
            msg_type = self.matching(_MSG_TYPE)[0]
        fields: tuple[Name, ...] = ()
        if lex.kind == "{":
            fields = self.field_block()
        rate = _NO_RATE
        if lex.kind == "@":
            rate = self.rate()
        self.optional_semicolon()
        return Topic(
            name,
            msg_type=msg_type,
            fields=fields,
            rate_hz=rate.hz,
            rate_tolerance_hz=rate.tolerance,
            window_s=rate.window,
            mismatch_threshold=rate.mismatch,
            span=self.span_from(start),
            rate_span=rate.span,
            tolerance_span=rate.tolerance_span,
            window_span=rate.window_span,
            mismatch_span=rate.mismatch_span,
        )

    def field_block(self) -> tuple[Name, ...]:
        """``"{" [FIELD ("," FIELD)* ","?] "}"``"""
        self.punctuation("{")
        lex = self.lex
        fields: list[Name] = []
        while lex.kind != "}":
            value, span = self.matching(_FIELD)
            fields.append(Name(_intern(value), span))
            if lex.kind != ",":
                break
            lex.advance()
        self.punctuation("}")
        return tuple(fields)

    def rate(self) -> _Rate:
        """``"@" NUMBER "Hz" rate_option*``; the last of a repeated option counts."""
        start = self.here()
        self.punctuation("@")
        hz = self.number()
        self.keyword("Hz")
        rate = _Rate(hz, self.span_from(start))
        lex = self.lex
        while True:
            start = self.here()
            if lex.kind == "PLUS_MINUS":
                lex.advance()
                rate.tolerance = self.number()
                self.keyword("Hz")
                rate.tolerance_span = self.span_from(start)
            elif lex.kind == "NAME" and lex.value == "window":
                lex.advance()
                length = self.number()
                unit = self.word(TIME_UNITS)
                rate.window = length / (1000.0 if unit == "ms" else 1.0)
                rate.window_span = self.span_from(start)
            elif lex.kind == "NAME" and lex.value == "mismatch":
                lex.advance()
                rate.mismatch = self.integer()
                rate.mismatch_span = self.span_from(start)
            else:
                return rate

    # node: "node" NAME [drives] [on_machine] [container] [node_body] ";"? ---------------
    def node(self) -> Node:
        start = self.keyword("node")
        name = self.name()
        lex = self.lex
        drives: tuple[Name, ...] = ()
        if lex.kind == "NAME" and lex.value == "drives":
            lex.advance()
            drives = self.name_list()
        machine: Name | None = None
        if lex.kind == "NAME" and lex.value == "on":
            lex.advance()
            machine = self.name()
        container: Container | None = None
        if lex.kind == "NAME" and lex.value == "in":
            container = self.container()
        body = _Body()
        if lex.kind == "{":
            self.node_body(body)
        self.optional_semicolon()
        return Node(
            name,
            drives=drives,
            subscribes=tuple(body.subscribes),
            publishes=tuple(body.publishes),
            limits=body.limits,
            diagnostics=tuple(body.reports),
            machine=machine,
            container=container,
            span=self.span_from(start),
        )

    def container(self) -> Container:
        """``"in" "container" NAME "via" CONTAINER_RUNTIME``"""
        self.keyword("in")
        self.keyword("container")
        name = self.name()
        self.keyword("via")
        return Container(name, self.word(CONTAINER_RUNTIMES))

    def node_body(self, body: _Body) -> None:
        """``"{" node_stmt* "}"``, each statement ending in an optional ``;``."""
        self.punctuation("{")
        lex = self.lex
        while lex.kind == "NAME":
            statement = lex.value
            if statement == "subscribes":
                lex.advance()
                body.subscribes.extend(self.name_list())
            elif statement == "publishes":
                lex.advance()
                self.publishes(body.publishes)
            elif statement == "reports":
                lex.advance()
                body.reports.extend(self.name_list())
            elif statement == "limits":
                body.limits = self.limits(body.limits)  # its span takes in its ';'
                continue
            else:
                raise Bail
            self.optional_semicolon()
        self.punctuation("}")

    def publishes(self, publications: list[Publication]) -> None:
        """After ``publishes``: ``name_list`` or ``NAME "from" name_list``."""
        first = self.name()
        lex = self.lex
        if lex.kind == "NAME" and lex.value == "from":
            lex.advance()
            publications.append(Publication(first, self.name_list()))
            return
        publications.append(Publication(first))
        while lex.kind == ",":
            lex.advance()
            publications.append(Publication(self.name()))

    def limits(self, before: Limits) -> Limits:
        """``"limits" limit ("," limit)*``: the first cpu and the first mem of the statement
        count, over what an earlier statement set; the span is this statement's."""
        start = self.keyword("limits")
        lex = self.lex
        cpu: float | None = None
        mem: int | None = None
        while True:
            if lex.kind == "NAME" and lex.value == "cpu":
                lex.advance()
                value = self.number()
                self.punctuation("%")
                cpu = value if cpu is None else cpu
            elif lex.kind == "NAME" and lex.value == "mem":
                lex.advance()
                amount = self.number()
                unit = self.word(MEM_UNIT_NAMES)
                mem = round(amount * MEM_UNITS[unit]) if mem is None else mem
            else:
                raise Bail
            if lex.kind != ",":
                break
            lex.advance()
        self.optional_semicolon()
        return Limits(
            cpu=cpu if cpu is not None else before.cpu,
            mem=mem if mem is not None else before.mem,
            span=self.span_from(start),
        )

    # relate / interval ---------------------------------------------------------------
    def side(self) -> FieldRef:
        """``FIELD_REF | "I" "(" FIELD_REF ")"``"""
        lex = self.lex
        if lex.kind == "FIELD_REF":
            value = lex.value
            line, column = lex.line, lex.column
            lex.advance()
            return FieldRef.parse(value, Span(self.path, line, column, line, column + len(value)))
        start = self.keyword("I")
        self.punctuation("(")
        if lex.kind != "FIELD_REF":
            raise Bail
        topic, _, field = lex.value.partition(".")
        lex.advance()
        self.punctuation(")")
        return FieldRef(topic, field, self.span_from(start), integrated=True)

    def pair(self) -> tuple[FieldRef, FieldRef]:
        """``side "~" side``"""
        a = self.side()
        lex = self.lex
        lex.read_as("~")  # to the master pattern, '~' starts a name
        lex.advance()
        return a, self.side()

    def relate(self) -> Related:
        start = self.keyword("relate")
        a, b = self.pair()
        self.optional_semicolon()
        return Related(a, b, span=self.span_from(start))

    def interval(self) -> Interval:
        start = self.keyword("interval")
        a, b = self.pair()
        self.keyword("within")
        diff = self.number()
        self.optional_semicolon()
        return Interval(a, b, diff, span=self.span_from(start))


class _Rate:
    """A topic's rate and its options, with where each is written, while they are read."""

    __slots__ = (
        "hz",
        "mismatch",
        "mismatch_span",
        "span",
        "tolerance",
        "tolerance_span",
        "window",
        "window_span",
    )

    def __init__(self, hz: float | None, span: Span | None) -> None:
        self.hz = hz
        self.span = span
        self.tolerance: float | None = None
        self.tolerance_span: Span | None = None
        self.window: float | None = None
        self.window_span: Span | None = None
        self.mismatch: int | None = None
        self.mismatch_span: Span | None = None


_NO_RATE = _Rate(None, None)


class _Body:
    """A node body's statements while they are read."""

    __slots__ = ("limits", "publishes", "reports", "subscribes")

    def __init__(self) -> None:
        self.subscribes: list[Name] = []
        self.publishes: list[Publication] = []
        self.reports: list[Name] = []
        self.limits = _NO_LIMITS


def fast_parse(text: str, path: str) -> tuple[Model, list[Token]]:
    """The model (comments not yet attached) and its comment tokens; :class:`Bail` if unsure."""
    parser = _Parser(text, path)
    return parser.model(), parser.lex.comments
