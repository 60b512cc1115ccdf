"""A fast path for :func:`rac.parse.parse_ram`: a hand-written scanner for valid models.

Lark's LALR parser is the definition of the language and the source of every syntax
error message, but its Python lexer costs about 20 µs a token, several seconds for a
10,000-node model.  This module reads the same grammar (``rac/grammar/ram.lark``) with
the same terminal regular expressions, state by state, as a recursive descent over the
text, and builds exactly the IR the Lark path builds: the same values, the same spans
(a declaration's span runs from its keyword to its last token, ``;`` included), the same
comments.  Declarations in the usual layout (one line each; a node's statements one a line)
are read a whole line per regular-expression match, everything else token by token.

It is deliberately strict: whenever the input strays from what it can read with certainty
(a syntax error, a keyword glued to a following word, a list or a declaration that goes on
past the end of its line in one of the one-line shortcuts), it raises :class:`Bail` and
:func:`rac.parse.parse_ram` parses the text again with Lark, which then either accepts it or
reports the error in its own words.  So the fast path makes compilation quicker but never
changes what is accepted or what an error says; ``tests/test_fastparse.py`` checks it
against Lark on the example models, odd layouts, mutants and random models.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from typing import Any

from lark import Token

from rac.errors import Span
from rac.ir import (
    CONTAINER_RUNTIMES,
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

# Atomic groups ``(?>...)`` are Python 3.11+.  On 3.10 the patterns compile without them
# (plain groups, which may backtrack into a terminal) and :func:`fast_parse` always bails,
# so Lark reads every model there: slower, never different.
_ATOMIC = sys.version_info >= (3, 11)


def _compile(pattern: str) -> re.Pattern[str]:
    return re.compile(pattern if _ATOMIC else pattern.replace("(?>", "(?:"))


# The terminals of ram.lark, verbatim.
_NAME = _compile(r"[A-Za-z_~\/][A-Za-z0-9_~\/\-]*")
_FIELD_REF = _compile(
    r"[A-Za-z_~\/][A-Za-z0-9_~\/\-]*\.[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*"
)
_MSG_TYPE = _compile(r"[A-Za-z_][A-Za-z0-9_]*(\/[A-Za-z_][A-Za-z0-9_]*)+")
_FIELD = _compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
_NUMBER = _compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?")
_INT = _compile(r"\d+")
_ADDRESS = _compile(r"[A-Za-z0-9][A-Za-z0-9.:\-]*")
_WS = _compile(r"[ \t\f\r\n]*")
_COMMENT = _compile(r"#[^\n]*")
# Comma-separated runs of names or fields on one line (atomic groups: each item matches
# exactly as the terminal alone would).
_NAME_RUN = _compile(rf"(?>{_NAME.pattern})(?:[ \t]*,[ \t]*(?>{_NAME.pattern}))*")
_FIELD_RUN = _compile(rf"(?>{_FIELD.pattern})(?:[ \t]*,[ \t]*(?>{_FIELD.pattern}))*")
# A whole topic declaration on one line, each terminal in an atomic group so that it
# matches exactly as the lexer would match it; keywords must end where a word ends.
_END = r"(?![A-Za-z0-9_])"
_TOPIC_OPTION = _compile(
    rf"(?:\+-|±)[ \t]*(?P<tolerance>(?>{_NUMBER.pattern}))[ \t]*Hz{_END}"
    rf"|window{_END}[ \t]*(?P<window>(?>{_NUMBER.pattern}))[ \t]*(?P<unit>ms|s){_END}"
    rf"|mismatch{_END}[ \t]*(?P<mismatch>(?>{_INT.pattern}))"
)
_TOPIC_LINE = _compile(
    rf"topic[ \t]+(?P<name>(?>{_NAME.pattern}))"
    rf"(?:[ \t]*:[ \t]*(?P<type>(?>{_MSG_TYPE.pattern})))?"
    rf"(?:[ \t]*\{{[ \t]*(?:(?P<fields>{_FIELD_RUN.pattern})[ \t]*(?:,[ \t]*)?)?\}})?"
    rf"(?:[ \t]*@[ \t]*(?P<rate>(?>{_NUMBER.pattern}))[ \t]*Hz{_END}"
    rf"(?P<options>(?:[ \t]*(?:{_TOPIC_OPTION.pattern}))*))?"
    r"(?=[ \t]*(?:[\n#;]|\Z))"
)
_TOPIC_GOES_ON = frozenset(":{@+±")
# Keywords are string terminals; reading a whole word and comparing it is stricter.
_WORD = _compile(r"[A-Za-z_][A-Za-z0-9_]*")
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

# Lark's contextual lexer reads a keyword as a name wherever only a name can come (after
# 'node', in a list after ','), and this reader reads names exactly there, so a name spelled
# like a keyword ('node from', 'publishes from from /a') is a name here too.


# A node's head up to its '{' on the same line.
_NODE_HEAD = _compile(
    rf"node[ \t]+(?P<name>(?>{_NAME.pattern}))"
    rf"(?:[ \t]+drives[ \t]+(?P<drives>{_NAME_RUN.pattern}))?(?=[ \t]*\{{)"
)
# Node statements on one line.
_LINE_END = r"(?=[ \t]*(?:[\n#;}]|\Z))"
_STATEMENT_LINE = _compile(
    rf"(?P<kind>subscribes|publishes|reports)[ \t]+(?P<names>{_NAME_RUN.pattern})"
    rf"(?:[ \t]+from[ \t]+(?P<inputs>{_NAME_RUN.pattern}))?{_LINE_END}"
)
_UNITS = "|".join(sorted(MEM_UNITS, key=len, reverse=True))
_LIMIT = _compile(
    rf"cpu[ \t]+(?P<cpu>(?>{_NUMBER.pattern}))[ \t]*%"
    rf"|mem[ \t]+(?P<mem>(?>{_NUMBER.pattern}))[ \t]*(?P<unit>{_UNITS}){_END}"
)
_ANY_LIMIT = re.sub(r"\(\?P<\w+>", "(?:", _LIMIT.pattern)
_LIMITS_LINE = _compile(
    rf"limits[ \t]+(?P<limits>(?:{_ANY_LIMIT})(?:[ \t]*,[ \t]*(?:{_ANY_LIMIT}))*){_LINE_END}"
)


# Whole lines in the usual layout, each read with one match (``_Reader.model``).  The
# terminals are those above with their groups made non-capturing (``m.groups()`` then holds
# only the parts this reader uses), each in an atomic group so that it matches exactly as the
# lexer alone would; whitespace within a line is Lark's WS without the newline.  A line ends
# in ``_TAIL``: an optional ';', an optional comment and the newline (or the end of the text);
# its first, empty group marks where the last token before it ends.  Whatever these patterns
# do not match is read token by token as before, and a declaration read here is read again
# token by token when the next line turns out to continue it.
def _plain(pattern: str) -> str:
    """``pattern`` with every group, named or not, made non-capturing."""
    return re.sub(r"\((?!\?)|\(\?P<\w+>", "(?:", pattern)


_S = r"[ \t\f\r]"
_TAIL = rf"(){_S}*(;)?{_S}*(#[^\n]*)?(?:\n|\Z)"
_A_NAME = rf"(?>{_NAME.pattern})"
_A_FIELD = rf"(?>{_plain(_FIELD.pattern)})"
_A_FIELD_REF = rf"(?>{_plain(_FIELD_REF.pattern)})"
_A_NUMBER = rf"(?>{_plain(_NUMBER.pattern)})"
_NAMES = rf"{_A_NAME}(?:{_S}*,{_S}*{_A_NAME})*"
_FIELDS = rf"{_A_FIELD}(?:{_S}*,{_S}*{_A_FIELD})*"
_OPTION = _compile(
    rf"(?:\+-|±){_S}*(?P<tolerance>{_A_NUMBER}){_S}*Hz{_END}"
    rf"|window{_END}{_S}*(?P<window>{_A_NUMBER}){_S}*(?P<unit>ms|s){_END}"
    rf"|mismatch{_END}{_S}*(?P<mismatch>(?>\d+))"
)
_LIMIT_S = _compile(
    rf"cpu{_S}+(?P<cpu>{_A_NUMBER}){_S}*%"
    rf"|mem{_S}+(?P<mem>{_A_NUMBER}){_S}*(?P<unit>{_UNITS}){_END}"
)
_HARDWARE_LINE = _compile(
    rf"hardware{_S}+({_A_NAME})((?:{_S}+(?:switchable|channel{_S}+(\d+)){_END})*){_TAIL}"
)
_TOPIC_FAST = _compile(
    rf"topic{_S}+({_A_NAME})"
    rf"(?:{_S}*:{_S}*((?>{_plain(_MSG_TYPE.pattern)})))?"
    rf"(?:{_S}*\{{{_S}*(?:({_FIELDS}){_S}*(?:,{_S}*)?)?\}})?"
    rf"(?:{_S}*@{_S}*({_A_NUMBER}){_S}*Hz{_END}((?:{_S}*(?:{_plain(_OPTION.pattern)}))*))?" + _TAIL
)
_NODE_LINE = _compile(
    rf"node{_S}+({_A_NAME})(?:{_S}+drives{_S}+({_NAMES}))?{_S}*\{{{_S}*(#[^\n]*)?\n"
)
_BODY_LINE = _compile(
    rf"{_S}*()(?:(?:(subscribes|publishes|reports){_S}+({_NAMES})(?:{_S}+from{_S}+({_NAMES}))?"
    rf"|limits{_S}+((?:{_plain(_LIMIT_S.pattern)})(?:{_S}*,{_S}*(?:{_plain(_LIMIT_S.pattern)}))*))"
    rf"{_S}*(;)?)?{_S}*(#[^\n]*)?\n"
)
_CPU_MEM = _compile(
    rf"cpu{_S}+({_A_NUMBER}){_S}*%{_S}*,{_S}*mem{_S}+({_A_NUMBER}){_S}*({_UNITS}){_END}"
)
_CLOSE_LINE = _compile(rf"{_S}*\}}{_TAIL}")
# Either side may be 'I(' FIELD_REF ')' (an integrated field) written without blanks.
_RELATE_LINE = _compile(
    rf"relate{_S}+(I\()?({_A_FIELD_REF})(?(1)\)){_S}*~{_S}*(I\()?({_A_FIELD_REF})(?(3)\)){_TAIL}"
)
_INTERVAL_LINE = _compile(
    rf"interval{_S}+({_A_FIELD_REF}){_S}*~{_S}*({_A_FIELD_REF})"
    rf"{_S}*within{_END}{_S}*({_A_NUMBER}){_TAIL}"
)
_NO_LIMITS = Limits()
# A name or a field in a run of them (neither holds a ',' or a blank).
_ITEM = _compile(r"[^ \t\f\r,]+")


# The one-line shortcuts build spans and names with the IR's own constructors.
_span = Span


def _name(value: str, span: Span) -> Name:
    """A name whose text is interned: a topic named in ten places is then one string, so
    the passes' many dict and set lookups by name find it by identity (and a large model
    takes less memory)."""
    return Name(_intern(value), span)


_intern = sys.intern


def _first_limits(run: str) -> tuple[float | None, int | None]:
    """The first cpu and the first mem limit in ``run``, the limits of one statement."""
    both = _CPU_MEM.fullmatch(run)
    if both is not None:  # the usual 'cpu N %, mem N UNIT'
        return float(both[1]), round(float(both[2]) * MEM_UNITS[both[3]])
    cpu: float | None = None
    mem: int | None = None
    for limit in _LIMIT_S.finditer(run):
        if limit["cpu"] is not None:
            if cpu is None:
                cpu = float(limit["cpu"])
        elif mem is None:
            mem = round(float(limit["mem"]) * MEM_UNITS[limit["unit"]])
    return cpu, mem


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

    def run(
        self,
        pattern: re.Pattern[str],
        item: re.Pattern[str],
        names: list[Name],
        where: tuple[int, int] | None = None,
    ) -> None:
        """Read ``A, B, C`` on one line in one go: the items of ``pattern``, a comma-separated
        run of ``item`` tokens, which is exactly what reading them one by one would give.

        With ``where``, the run was already matched there (on the current line) by a larger
        pattern, and nothing is consumed."""
        text, path = self.text, self.path
        if where is None:
            m = pattern.match(text, self.pos)
            if m is None:
                raise Bail
            where = m.span()
            self._take(m.end())
        line, base = self.line, self.line_start - 1
        for token in item.finditer(text, *where):
            value = token.group()
            names.append(
                Name(value, Span(path, line, token.start() - base, line, token.end() - base))
            )

    def statement_line(self, m: re.Match[str]) -> tuple[str, list[Name]]:
        """``subscribes``/``publishes``/``reports`` and its names, from one regex match."""
        kind = m["kind"]
        names: list[Name] = []
        self.run(_NAME_RUN, _NAME, names, m.span("names"))
        if m["inputs"] is not None and (kind != "publishes" or len(names) != 1):
            raise Bail
        return kind, names

    def name_list(self) -> tuple[Name, ...]:
        names: list[Name] = []
        while True:
            self.run(_NAME_RUN, _NAME, names)
            self.skip()
            if self.peek_char() != ",":
                return tuple(names)
            self.char(",")
            self.skip()

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
        machines: list[Machine] = []
        text = self.text
        size = len(text)
        # The last declaration when a one-line pattern read it: its list, the token-by-token
        # reader of its kind and the reader's state before it (pos, line, line_start, number
        # of comments), to read it again should the next token turn out to continue it.
        undo: tuple[list[Any], Callable[[], Any], int, int, int, int] | None = None
        while True:
            pos = self.pos
            if text[pos : pos + 1] in _SPACE_OR_HASH:
                self.skip()
                pos = self.pos
            if pos >= size:
                break
            first = text[pos]
            line, line_start, ncomments = self.line, self.line_start, len(self.comments)
            if first == "n" and (m := _NODE_LINE.match(text, pos)) is not None:
                nodes.append(self.node_lines(m))
                undo = (nodes, self.node, pos, line, line_start, ncomments)
                continue
            if first == "t" and (m := _TOPIC_FAST.match(text, pos)) is not None:
                topics.append(self.topic_fast(m))
                undo = (topics, self.topic, pos, line, line_start, ncomments)
                continue
            if first == "h" and (m := _HARDWARE_LINE.match(text, pos)) is not None:
                hardware.append(self.hardware_line(m))
                undo = (hardware, self.hardware, pos, line, line_start, ncomments)
                continue
            if first == "r" and (m := _RELATE_LINE.match(text, pos)) is not None:
                related.append(self.relate_line(m))
                undo = (related, self.relate, pos, line, line_start, ncomments)
                continue
            if first == "i" and (m := _INTERVAL_LINE.match(text, pos)) is not None:
                intervals.append(self.interval_line(m))
                undo = (intervals, self.interval, pos, line, line_start, ncomments)
                continue
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
            elif word == "machine":
                machines.append(self.machine())
            elif undo is not None:
                # The last line read in one go goes on here: read it again token by token.
                items, read, self.pos, self.line, self.line_start, ncomments = undo
                del self.comments[ncomments:]
                items[-1] = read()
            else:
                raise Bail
            undo = None
        model = Model(
            name=header,
            hardware=tuple(hardware),
            topics=tuple(topics),
            nodes=tuple(nodes),
            related=tuple(related),
            intervals=tuple(intervals),
            machines=tuple(machines),
            path=self.path,
        )
        return model, self.comments

    # one-line shortcuts --------------------------------------------------------
    def _names(self, start: int, run: str, line: int, base: int, names: list[Name]) -> None:
        """The items of ``run``, a comma-separated run of names or fields matched at
        ``start`` on line ``line`` (whose first character is at ``base + 1``)."""
        path = self.path
        column = start - base
        if "," not in run:  # one item
            names.append(_name(run, _span(path, line, column, line, column + len(run))))
            return
        items = run.split(", ")
        if len(items) == run.count(",") + 1 == run.count(" ") + 1 and run.isprintable():
            # Exactly ', ' between the items (the usual layout): no regex needed.
            for value in items:
                end = column + len(value)
                names.append(_name(value, _span(path, line, column, line, end)))
                column = end + 2
            return
        for token in _ITEM.finditer(run):
            s, e = token.span()
            names.append(
                _name(token.group(), _span(path, line, start + s - base, line, start + e - base))
            )

    def _comment(self, start: int, value: str, line: int, base: int) -> None:
        column = start - base
        end = start + len(value)
        self.comments.append(
            Token(
                "COMMENT",
                value,
                start_pos=start,
                line=line,
                column=column,
                end_line=line,
                end_column=end - base,
                end_pos=end,
            )
        )

    def _next_line(self, end: int) -> None:
        """Move to ``end``, the end of a line read in one go (after its newline if any)."""
        self.pos = end
        if self.text[end - 1] == "\n":
            self.line += 1
            self.line_start = end

    def hardware_line(self, m: re.Match[str]) -> Hardware:
        name, options, channel, _, semi, comment = m.groups()
        path, line, base = self.path, self.line, self.line_start - 1
        column = m.start(1) - base
        end = m.end(5) if semi is not None else m.start(4)
        if comment is not None:
            self._comment(m.start(6), comment, line, base)
        self._next_line(m.end())
        return Hardware(
            _name(name, _span(path, line, column, line, column + len(name))),
            switchable="switchable" in options,
            channel=int(channel) if channel is not None else None,
            span=_span(path, line, m.start() - base, line, end - base),
        )

    def topic_fast(self, m: re.Match[str]) -> Topic:
        name, msg_type, field_run, rate, options, _, semi, comment = m.groups()
        path, line, base = self.path, self.line, self.line_start - 1
        column = m.start(1) - base
        fields: list[Name] = []
        if field_run is not None:
            self._names(m.start(3), field_run, line, base, fields)
        tolerance: float | None = None
        window: float | None = None
        mismatch: int | None = None
        if options:
            for option in _OPTION.finditer(options):
                if option["tolerance"] is not None:
                    tolerance = float(option["tolerance"])
                elif option["window"] is not None:
                    scale = 1000.0 if option["unit"] == "ms" else 1.0
                    window = float(option["window"]) / scale
                else:
                    mismatch = int(option["mismatch"])
        end = m.end(7) if semi is not None else m.start(6)
        if comment is not None:
            self._comment(m.start(8), comment, line, base)
        self._next_line(m.end())
        return Topic(
            _name(name, _span(path, line, column, line, column + len(name))),
            msg_type=msg_type,
            fields=tuple(fields),
            rate_hz=float(rate) if rate is not None else None,
            rate_tolerance_hz=tolerance,
            window_s=window,
            mismatch_threshold=mismatch,
            span=_span(path, line, m.start() - base, line, end - base),
        )

    def node_lines(self, m: re.Match[str]) -> Node:
        """A node whose head ends its line with '{', each statement on a line of its own and
        '}' on a line of its own; anything else is read again token by token."""
        text, path = self.text, self.path
        first_line, line_start, ncomments = self.line, self.line_start, len(self.comments)
        line, base = first_line, line_start - 1
        name, drive_run, comment = m.groups()
        name_column = m.start(1) - base
        drives: list[Name] = []
        if drive_run is not None:
            self._names(m.start(2), drive_run, line, base, drives)
        if comment is not None:
            self._comment(m.start(3), comment, line, base)
        start_column = m.start() - base
        subscribes: list[Name] = []
        publishes: list[Publication] = []
        diagnostics: list[Name] = []
        limits = _NO_LIMITS
        pos = m.end()
        line += 1
        match = _BODY_LINE.match
        while (b := match(text, pos)) is not None:
            base = pos - 1
            _, kind, names, inputs, limit_run, semi, comment = b.groups()
            if kind is not None:
                if inputs is not None and (kind != "publishes" or "," in names):
                    break  # not a statement: let the token-by-token reader bail
                if kind == "subscribes":
                    self._names(b.start(3), names, line, base, subscribes)
                elif kind == "reports":
                    self._names(b.start(3), names, line, base, diagnostics)
                elif inputs is None:
                    topics: list[Name] = []
                    self._names(b.start(3), names, line, base, topics)
                    publishes.extend([Publication(topic) for topic in topics])
                else:
                    column = b.start(3) - base
                    topic = _name(names, _span(path, line, column, line, column + len(names)))
                    affected_by: list[Name] = []
                    self._names(b.start(4), inputs, line, base, affected_by)
                    publishes.append(Publication(topic, tuple(affected_by)))
            elif limit_run is not None:
                cpu, mem = _first_limits(limit_run)
                end = b.end(6) if semi is not None else b.end(5)
                limits = Limits(
                    cpu=cpu if cpu is not None else limits.cpu,
                    mem=mem if mem is not None else limits.mem,
                    span=_span(path, line, b.start(1) - base, line, end - base),
                )
            if comment is not None:
                self._comment(b.start(7), comment, line, base)
            pos = b.end()
            line += 1
        else:
            c = _CLOSE_LINE.match(text, pos)
            if c is not None:
                _, semi, comment = c.groups()
                base = pos - 1
                end = c.end(2) if semi is not None else c.start(1)
                if comment is not None:
                    self._comment(c.start(3), comment, line, base)
                self.line = line
                self.line_start = pos
                self._next_line(c.end())
                return Node(
                    _name(
                        name,
                        _span(path, first_line, name_column, first_line, name_column + len(name)),
                    ),
                    drives=tuple(drives),
                    subscribes=tuple(subscribes),
                    publishes=tuple(publishes),
                    limits=limits,
                    diagnostics=tuple(diagnostics),
                    span=_span(path, first_line, start_column, line, end - base),
                )
        # Not in the usual layout: read the node token by token.
        self.pos, self.line, self.line_start = m.start(), first_line, line_start
        del self.comments[ncomments:]
        return self.node()

    def relate_line(self, m: re.Match[str]) -> Related:
        semi, comment = m[6], m[7]
        path, line, base = self.path, self.line, self.line_start - 1
        end = m.end(6) if semi is not None else m.start(5)
        if comment is not None:
            self._comment(m.start(7), comment, line, base)
        self._next_line(m.end())
        sides = []
        for group in (2, 4):  # each side's FIELD_REF, after its optional 'I(' group
            text = m[group]
            if m[group - 1] is None:
                column = m.start(group) - base
                span = _span(path, line, column, line, column + len(text))
                sides.append(FieldRef.parse(text, span))
            else:
                # I(...): the span runs from the 'I' to the ')'.
                column = m.start(group - 1) - base
                span = _span(path, line, column, line, m.end(group) + 1 - base)
                topic, _, field = text.partition(".")
                sides.append(FieldRef(topic, field, span, integrated=True))
        span = _span(path, line, m.start() - base, line, end - base)
        return Related(sides[0], sides[1], span=span)

    def interval_line(self, m: re.Match[str]) -> Interval:
        a, b, diff, _, semi, comment = m.groups()
        path, line, base = self.path, self.line, self.line_start - 1
        end = m.end(5) if semi is not None else m.start(4)
        a_column, b_column = m.start(1) - base, m.start(2) - base
        if comment is not None:
            self._comment(m.start(6), comment, line, base)
        self._next_line(m.end())
        return Interval(
            FieldRef.parse(a, _span(path, line, a_column, line, a_column + len(a))),
            FieldRef.parse(b, _span(path, line, b_column, line, b_column + len(b))),
            float(diff),
            span=_span(path, line, m.start() - base, line, end - base),
        )

    # token by token ------------------------------------------------------------
    def machine(self) -> Machine:
        start = self.keyword("machine")
        self.skip()
        name = self.name()
        self.skip()
        address: str | None = None
        if self.peek_word() == "address":
            self.keyword("address")
            self.skip()
            address = self.regex(_ADDRESS)
            self.skip()
        if self.peek_char() == ";":
            self.char(";")
        return Machine(name, address=address, span=self.span_from(start))

    def placement(self) -> tuple[Name | None, Container | None]:
        """``on MACHINE`` and ``in container NAME via RUNTIME`` after a node's name."""
        machine: Name | None = None
        container: Container | None = None
        if self.peek_word() == "on":
            self.keyword("on")
            self.skip()
            machine = self.name()
            self.skip()
        if self.peek_word() == "in":
            self.keyword("in")
            self.skip()
            self.keyword("container")
            self.skip()
            cname = self.name()
            self.skip()
            self.keyword("via")
            self.skip()
            runtime = self.peek_word()
            if runtime not in CONTAINER_RUNTIMES:
                raise Bail
            self.keyword(runtime)
            self.skip()
            container = Container(cname, runtime)
        return machine, container

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
        if (m := _TOPIC_LINE.match(self.text, self.pos)) is not None:
            return self.topic_line(m)
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
                    self.run(_FIELD_RUN, _FIELD, fields)
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

    def topic_line(self, m: re.Match[str]) -> Topic:
        """A topic declared on one line (the usual layout), read with one regex match."""
        text, path = self.text, self.path
        line, base = self.line, self.line_start - 1
        start = (line, m.start() - base)
        name_start, name_end = m.span("name")
        name = Name(m["name"], Span(path, line, name_start - base, line, name_end - base))
        fields: list[Name] = []
        if m["fields"] is not None:
            for token in _FIELD.finditer(text, *m.span("fields")):
                value = token.group()
                span = Span(path, line, token.start() - base, line, token.end() - base)
                fields.append(Name(value, span))
        options: dict[str, Any] = {}
        if m["options"]:
            for option in _TOPIC_OPTION.finditer(text, *m.span("options")):
                if option["tolerance"] is not None:
                    options["tolerance"] = float(option["tolerance"])
                elif option["window"] is not None:
                    scale = 1000.0 if option["unit"] == "ms" else 1.0
                    options["window"] = float(option["window"]) / scale
                else:
                    options["mismatch"] = int(option["mismatch"])
        self._take(m.end())
        self.skip()
        if self.peek_char() == ";":
            self.char(";")
        elif self.peek_char() in _TOPIC_GOES_ON or self.peek_word() in ("window", "mismatch"):
            raise Bail  # the declaration continues on the next line: read it token by token
        return Topic(
            name,
            msg_type=m["type"],
            fields=tuple(fields),
            rate_hz=float(m["rate"]) if m["rate"] is not None else None,
            rate_tolerance_hz=options.get("tolerance"),
            window_s=options.get("window"),
            mismatch_threshold=options.get("mismatch"),
            span=self.span_from(start),
        )

    def node(self) -> Node:
        drives: tuple[Name, ...] = ()
        machine: Name | None = None
        container: Container | None = None
        if (m := _NODE_HEAD.match(self.text, self.pos)) is not None:
            # 'node NAME drives A, B {' on one line, read with one regex match.
            line, base = self.line, self.line_start - 1
            start = (line, m.start() - base)
            name_start, name_end = m.span("name")
            name = Name(m["name"], Span(self.path, line, name_start - base, line, name_end - base))
            if m["drives"] is not None:
                driven: list[Name] = []
                self.run(_NAME_RUN, _NAME, driven, m.span("drives"))
                drives = tuple(driven)
            self._take(m.end())
            self.skip()
        else:
            start = self.keyword("node")
            self.skip()
            name = self.name()
            self.skip()
            if self.peek_word() == "drives":
                self.keyword("drives")
                self.skip()
                drives = self.name_list()
                self.skip()
            machine, container = self.placement()
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
                if (m := _STATEMENT_LINE.match(self.text, self.pos)) is not None:
                    statement, names = self.statement_line(m)
                    if statement == "subscribes":
                        subscribes.extend(names)
                    elif statement == "reports":
                        diagnostics.extend(names)
                    elif m["inputs"] is not None:
                        inputs: list[Name] = []
                        self.run(_NAME_RUN, _NAME, inputs, m.span("inputs"))
                        publishes.append(Publication(names[0], tuple(inputs)))
                    else:
                        publishes.extend(Publication(n) for n in names)
                    self._take(m.end())
                    self.skip()
                    if self.peek_char() == "," or self.peek_word() == "from":
                        raise Bail  # the statement goes on on the next line
                    if self.peek_char() == ";":
                        self.char(";")
                    continue
                if (m := _LIMITS_LINE.match(self.text, self.pos)) is not None:
                    limits_start = (self.line, self.pos - self.line_start + 1)
                    first_cpu: float | None = None
                    first_mem: int | None = None
                    for limit in _LIMIT.finditer(self.text, *m.span("limits")):
                        if limit["cpu"] is not None:
                            if first_cpu is None:
                                first_cpu = float(limit["cpu"])
                        elif first_mem is None:
                            first_mem = round(float(limit["mem"]) * MEM_UNITS[limit["unit"]])
                    self._take(m.end())
                    self.skip()
                    if self.peek_char() == ",":
                        raise Bail  # the limits go on on the next line
                    if self.peek_char() == ";":
                        self.char(";")
                    limits = Limits(
                        cpu=first_cpu if first_cpu is not None else limits.cpu,
                        mem=first_mem if first_mem is not None else limits.mem,
                        span=self.span_from(limits_start),
                    )
                    continue
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
            machine=machine,
            container=container,
            span=self.span_from(start),
        )

    def field_ref(self) -> FieldRef:
        text, span = self.spanned(_FIELD_REF)
        return FieldRef.parse(text, span)

    def side(self) -> FieldRef:
        """A field reference or ``I(`` field reference ``)``; the lexer tries FIELD_REF first."""
        if _FIELD_REF.match(self.text, self.pos) is not None:
            return self.field_ref()
        start = self.keyword("I")
        self.skip()
        self.char("(")
        self.skip()
        text = self.regex(_FIELD_REF)
        self.skip()
        self.char(")")
        topic, _, field = text.partition(".")
        return FieldRef(topic, field, self.span_from(start), integrated=True)

    def _pair(self, keyword: str) -> tuple[tuple[int, int], FieldRef, FieldRef]:
        start = self.keyword(keyword)
        self.skip()
        a = self.side()
        self.skip()
        self.char("~")
        self.skip()
        b = self.side()
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
    if not _ATOMIC:
        raise Bail("no atomic groups before Python 3.11")
    return _Reader(text, path).model()
