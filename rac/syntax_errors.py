"""Syntax errors of the ``.ram`` language, in words.

Lark's parser (:mod:`rac.parse`) says which token it met and which terminals it expected;
this module turns that into what a user reads: what was expected, in words, and where a
slip is common, what to write instead (a unit in another case or scale, a block left open,
``from`` after a list, ``=`` for ``~``, a keyword glued to the word after it).  The literal
text of each keyword terminal comes from the parser (``literals``), so that the grammar
stays the one place that spells them.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from lark import Token
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken
from lark.tree import Meta

from rac.errors import Diagnostic, Span, did_you_mean

# What each terminal means to a user, for "expected ..." messages.
TERMINAL_WORDS = {
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

# Keywords are whole words: one glued to the letters after it (``memory``, ``fromage``) is
# not that keyword.  The characters that continue a word:
WORD_CHARACTERS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_")
# The terminals of the grammar that are words of fixed spellings besides its string keywords.
WORD_TERMINALS = ("TIME_UNIT", "MEM_UNIT", "CONTAINER_RUNTIME")

# The units each unit terminal of the grammar accepts (rac/grammar/ram.lark).
UNITS = {
    "MEM_UNIT": ("GiB", "MiB", "KiB", "GB", "MB", "kB", "KB", "B"),
    "HZ": ("Hz",),
    "TIME_UNIT": ("ms", "s"),
}
_UNIT_WORDS = {"MEM_UNIT": "a memory unit", "HZ": "'Hz'", "TIME_UNIT": "a time unit"}
# Units the language does not take, as a factor and a unit it does: the hint gives the
# value converted (``0.1 kHz`` is 100 Hz), never the same number with another unit.
CONVERSIONS: dict[str, dict[str, tuple[float, str]]] = {
    "HZ": {
        "kHz": (1e3, "Hz"),
        "KHz": (1e3, "Hz"),
        "khz": (1e3, "Hz"),
        "MHz": (1e6, "Hz"),
        "mHz": (1e-3, "Hz"),
        "Hertz": (1.0, "Hz"),
        "hertz": (1.0, "Hz"),
    },
    "TIME_UNIT": {
        **dict.fromkeys(("sec", "secs", "second", "seconds", "S"), (1.0, "s")),
        **dict.fromkeys(("msec", "msecs", "millisecond", "milliseconds", "MS"), (1.0, "ms")),
        **dict.fromkeys(("us", "µs", "usec", "microseconds"), (1e-3, "ms")),
        **dict.fromkeys(("min", "mins", "minute", "minutes"), (60.0, "s")),
        **dict.fromkeys(("h", "hour", "hours"), (3600.0, "s")),
    },
    "MEM_UNIT": {
        **dict.fromkeys(("bytes", "byte"), (1.0, "B")),
        "TB": (1000.0, "GB"),
        "TiB": (1024.0, "GiB"),
    },
}

_DECLARATIONS = ("hardware", "topic", "node", "relate", "interval")
_NUMBER_BEFORE = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?\s*$")
_BLOCK_HEAD = re.compile(r"(?:^|(?<=[\s;}]))(node|topic)\s+([A-Za-z_~/][A-Za-z0-9_~/\-]*)")
_NAME = r"[A-Za-z_~/][A-Za-z0-9_~/\-]*"
_LIST_BEFORE_FROM = re.compile(rf"publishes\s+({_NAME}(?:\s*,\s*{_NAME})+)\s*$")
_LIST_AFTER = re.compile(rf"\s*({_NAME}(?:\s*,\s*{_NAME})*)")
_SIDE = r"(?:I\s*\(\s*[^\s()]+\s*\)|[^\s~=;]+)"
_RELATION = re.compile(rf"(relate|interval)\s+({_SIDE})\s*$")


def span_of_token(file: str, item: Token | Meta) -> Span:
    assert item.line is not None and item.column is not None
    end_line = item.end_line if item.end_line is not None else item.line
    end_col = item.end_column if item.end_column is not None else item.column + 1
    return Span(file, item.line, item.column, end_line, end_col)


class Words:
    """The expected terminals of a parser state as a user reads them."""

    def __init__(self, literals: Mapping[str, str]) -> None:
        self.literals = literals  # terminal name -> its text, for the string terminals

    def expected(self, terminals: set[str]) -> str:
        names = sorted({TERMINAL_WORDS.get(t, self.keyword(t)) for t in terminals})
        if len(names) == 1:
            return names[0]
        return ", ".join(names[:-1]) + " or " + names[-1]

    def keyword(self, terminal: str) -> str:
        """A keyword terminal as the user writes it: ``HZ`` -> ``'Hz'``."""
        return f"'{self.literals.get(terminal, terminal.lower())}'"

    def keyword_hint(self, word: str, terminals: set[str]) -> str | None:
        """Did-you-mean for a misspelt keyword (``subscribe`` for ``subscribes``)."""
        keywords = [self.literals[t] for t in terminals if t in self.literals]
        return did_you_mean(word, [k for k in keywords if k.isalpha()])


def syntax_error(
    err: UnexpectedInput, path: str, text: str, literals: Mapping[str, str]
) -> Diagnostic:
    """The diagnostic of one of Lark's parse errors."""
    words = Words(literals)
    line, column = max(err.line, 1), max(err.column, 1)
    if isinstance(err, UnexpectedToken) and err.token.type == "$END":
        line, column = end_position(text)
        span = Span(path, line, column, line, column + 1)
        opened = _open_block(text, len(text)) if "RBRACE" in err.expected else None
        if opened:
            message = f"unexpected end of file: {opened} is missing its '}}'"
            hint = f"expected {words.expected(err.expected)}"
            return Diagnostic("RAC002", message, span, hint=hint)
        return Diagnostic(
            "RAC002", f"unexpected end of file; expected {words.expected(err.expected)}", span
        )
    if isinstance(err, UnexpectedToken):
        special = _special_token_error(err, path, text, words)
        if special is not None:
            return special
        token = err.token
        message = f"unexpected '{token}'; expected {words.expected(err.expected)}"
        close = words.keyword_hint(str(token), err.expected)
        return Diagnostic("RAC001", message, span_of_token(path, token), hint=close)
    if isinstance(err, UnexpectedCharacters):
        span = Span(path, line, column, line, column + 1)
        pos = err.pos_in_stream
        char = text[pos] if pos is not None and pos < len(text) else "?"
        allowed = err.allowed or set()
        if char == "=" and "TILDE" in allowed and pos is not None:
            return _equals_for_tilde(path, text, pos, span)
        told = f"expected {words.expected(allowed)}" if allowed else None
        return Diagnostic("RAC003", f"unexpected character {char!r}", span, hint=told)
    if isinstance(err, UnexpectedEOF):
        line, column = end_position(text)
        span = Span(path, line, column, line, column + 1)
        return Diagnostic(
            "RAC002", f"unexpected end of file; expected {words.expected(set(err.expected))}", span
        )
    span = Span(path, line, column, line, column + 1)
    return Diagnostic("RAC001", "syntax error", span)


def glued_keyword_error(
    token: Token, path: str, text: str, expected: set[str], literals: Mapping[str, str]
) -> Diagnostic:
    """A keyword read out of the front of a longer word (``memory``: ``mem``, then ``ory``):
    the whole word is what was written, and it is no keyword."""
    words = Words(literals)
    start = token.start_pos if token.start_pos is not None else 0
    end = start
    while end < len(text) and text[end] in WORD_CHARACTERS:
        end += 1
    word = text[start:end]
    at = span_of(path, text, start, end)
    units = [t for t in expected if t in UNITS]
    number = _NUMBER_BEFORE.search(text[:start]) if units else None
    if number is not None:
        return _unit_error(path, text, number, word, at, units, words, expected)
    message = f"unexpected '{word}'; expected {words.expected(expected)}"
    return Diagnostic("RAC001", message, at, hint=words.keyword_hint(word, expected))


def _misspelt_unit(word: str, terminals: list[str]) -> str | None:
    """The unit ``word`` spells in another case (`Gb`, `hz`)."""
    for terminal in terminals:
        for unit in UNITS.get(terminal, ()):
            if word.lower() == unit.lower() and word != unit:
                return unit
    return None


def _converted(value: str, word: str, terminals: list[str]) -> str | None:
    """``0.1 kHz`` -> ``100 Hz``: the value in a unit the language takes."""
    for terminal in terminals:
        factor, unit = CONVERSIONS.get(terminal, {}).get(word, (0.0, ""))
        if unit:
            return f"{float(value) * factor:.12g} {unit}"
    return None


def _unit_error(
    path: str,
    text: str,
    number: re.Match[str],
    word: str,
    word_span: Span,
    units: list[str],
    words: Words,
    expected: set[str],
) -> Diagnostic:
    """A number followed by something that is not the unit expected there."""
    value = number.group().strip()
    misspelt = _misspelt_unit(word, units)
    if misspelt is not None:  # `1 Gb`, `10 hz`: the unit is there, in the wrong case
        message = f"unknown unit '{word}': expected {words.expected(expected)}"
        return Diagnostic("RAC001", message, word_span, hint=f"did you mean '{misspelt}'?")
    converted = _converted(value, word, units)
    if converted is not None:  # `0.1 kHz`: the same number in Hz would be wrong by 1000
        message = f"unknown unit '{word}': expected {words.expected(expected)}"
        same = converted == f"{float(value):.12g} {converted.split()[-1]}"
        said = "" if same else f"{value} {word} is {converted}: "
        return Diagnostic("RAC001", message, word_span, hint=f"{said}write '{converted}'")
    if word[:1].isalpha() and not _is_keyword_of_a_statement(word, words):
        # a word that could be a unit (`Hertz` is converted above; `kg` is no unit here)
        message = f"unknown unit '{word}' after {value}: expected {words.expected(expected)}"
        close = did_you_mean(word, [u for t in units for u in UNITS[t]])
        return Diagnostic("RAC001", message, word_span, hint=close)
    at = span_of(path, text, number.start(), number.start() + len(value))
    message = f"the number {value} needs its unit: expected {words.expected(expected)}"
    return Diagnostic("RAC001", message, at, hint=f"write e.g. '{value} {_unit_example(units)}'")


def _is_keyword_of_a_statement(word: str, words: Words) -> bool:
    """``node``, ``limits``...: the next statement, which means the unit was left out."""
    return word in words.literals.values()


def _unit_example(units: list[str]) -> str:
    return {"MEM_UNIT": "MB", "HZ": "Hz", "TIME_UNIT": "s"}[sorted(units)[0]]


def _special_token_error(
    err: UnexpectedToken, path: str, text: str, words: Words
) -> Diagnostic | None:
    """The syntax errors that read better in words than as 'unexpected X; expected Y'."""
    token = err.token
    start = token.start_pos if token.start_pos is not None else 0
    before = text[:start]
    # A number without its unit: the parser only notices at the next token, maybe lines on.
    units = [t for t in err.expected if t in _UNIT_WORDS]
    number = _NUMBER_BEFORE.search(before) if units else None
    if number is not None:
        word_span = span_of_token(path, token)
        return _unit_error(path, text, number, str(token), word_span, units, words, err.expected)
    # `mismatch 2.5`: the whole number ends at the dot, and '.5' is read as the next number.
    if str(token).startswith(".") and before[-1:].isdigit():
        digits = len(before) - len(before.rstrip("0123456789"))
        first = start - digits
        keyword = before[:first].split()[-1:] or ["this"]
        whole = text[first : token.end_pos]
        at = span_of(path, text, first, first + len(whole))
        message = f"'{keyword[0]}' takes a whole number, not {whole}"
        return Diagnostic("RAC001", message, at)
    # `publishes /a, /b from /c`: `from` belongs to one publication.
    if str(token) == "from":
        listed = _LIST_BEFORE_FROM.search(before)
        if listed is not None:
            return _from_after_a_list(path, text, token, listed.group(1))
    # A block left open: the next declaration is where the parser notices.
    if "RBRACE" in err.expected and str(token) in _DECLARATIONS:
        opened = _open_block(text, start)
        if opened:
            message = f"{opened} is missing its '}}' before this {token}"
            return Diagnostic(
                "RAC001", message, span_of_token(path, token), hint="add '}' to close it"
            )
    return None


def _split_names(listed: str) -> list[str]:
    return [n.strip() for n in listed.split(",")]


def _from_after_a_list(path: str, text: str, token: Token, listed: str) -> Diagnostic:
    topics = _split_names(listed)
    after = _LIST_AFTER.match(text, token.end_pos or 0)
    inputs = ", ".join(_split_names(after.group(1))) if after else "…"
    message = (
        f"'from' belongs to one published topic; {len(topics)} are listed before it "
        f"({', '.join(topics)})"
    )
    statements = " and ".join(f"'publishes {t} from {inputs}'" for t in topics)
    hint = f"write one statement per topic: {statements}"
    return Diagnostic("RAC001", message, span_of_token(path, token), hint=hint)


def _equals_for_tilde(path: str, text: str, pos: int, span: Span) -> Diagnostic:
    """``relate /a.x = /b.y``: the sides of a relation or an interval are joined by '~'."""
    line_start = text.rfind("\n", 0, pos) + 1
    line_end = text.find("\n", pos)
    head = _RELATION.search(text, line_start, pos)
    what = head.group(1) if head else "relate"
    message = f"unexpected '='; the two sides of {what} are joined by '~'"
    rest = text[pos : len(text) if line_end < 0 else line_end].lstrip("=")
    rest = rest.split("#")[0].strip().rstrip(";").strip()
    if head and rest:
        hint = f"write '{what} {head.group(2)} ~ {rest}'"
    else:
        hint = "write 'relate /a.x ~ /b.y', or 'interval /a.x ~ /b.y within D'"
    return Diagnostic("RAC003", message, span, hint=hint)


def span_of(path: str, text: str, start: int, end: int) -> Span:
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


def end_position(text: str) -> tuple[int, int]:
    lines = text.rstrip().splitlines() or [""]
    return len(lines), len(lines[-1]) + 1
