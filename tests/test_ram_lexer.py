"""rac.ram_lexer: its terminals are the grammar's, and it reads the tokens Lark reads.

The lexer copies the terminal patterns of rac/grammar/ram.lark; these tests hold the copies
equal to Lark's own reading of the grammar, so a grammar change that is not carried over
fails here.  The parser's differential tests against Lark are in tests/test_fastparse.py.
"""

from __future__ import annotations

import re

import pytest
from lark import Lark

from rac.fastparse import MEM_UNITS
from rac.parse import _commented_parser
from rac.ram_lexer import (
    CONTAINER_RUNTIMES,
    END,
    MEM_UNIT_NAMES,
    PLUS_MINUS,
    PUNCTUATION,
    TERMINALS,
    TIME_UNITS,
    WHITESPACE,
    Bail,
    Lexer,
)


def _lark() -> Lark:
    return _commented_parser()


def _pattern(name: str) -> tuple[str, str]:
    terminal = next(t for t in _lark().terminals if t.name == name)
    return terminal.pattern.type, terminal.pattern.value


def _alternatives(name: str) -> tuple[str, ...]:
    """The literals of a terminal written as ``"a" | "b"`` (Lark makes it ``(?:a|b)``)."""
    kind, value = _pattern(name)
    assert kind == "re" and value.startswith("(?:") and value.endswith(")")
    return tuple(re.sub(r"\\(.)", r"\1", value[3:-1]).split("|"))


@pytest.mark.parametrize("name", sorted(TERMINALS))
def test_regular_terminals_are_the_grammars(name: str) -> None:
    assert _pattern(name) == ("re", TERMINALS[name])


def test_string_terminals_are_the_grammars() -> None:
    assert _alternatives("PLUS_MINUS") == PLUS_MINUS
    assert _alternatives("TIME_UNIT") == TIME_UNITS
    assert _alternatives("MEM_UNIT") == MEM_UNIT_NAMES
    assert _alternatives("CONTAINER_RUNTIME") == CONTAINER_RUNTIMES
    assert set(MEM_UNITS) == set(MEM_UNIT_NAMES)
    kind, blanks = _pattern("WS")  # (?:[ \t\x0c\r\n])+
    assert kind == "re" and {c for c in WHITESPACE if re.fullmatch(blanks, c)} == set(WHITESPACE)
    assert not any(re.fullmatch(blanks, chr(c)) for c in range(0x3000) if chr(c) not in WHITESPACE)


def test_punctuation_is_the_grammars() -> None:
    singles = {
        t.pattern.value
        for t in _lark().terminals
        if t.pattern.type == "str" and len(t.pattern.value) == 1 and not t.pattern.value.isalpha()
    }
    assert singles == set(PUNCTUATION) | {"~"}  # '~' is read as a name first (the module)


def _keywords() -> dict[str, str]:
    name = re.compile(TERMINALS["NAME"])
    return {
        t.name: t.pattern.value
        for t in _lark().terminals
        if t.pattern.type == "str" and name.fullmatch(t.pattern.value)
    }


def test_every_keyword_is_read_as_a_name() -> None:
    for word in _keywords().values():
        lexer = Lexer(f"{word} ", "f.ram")
        assert (lexer.kind, lexer.value) == ("NAME", word)


def test_no_parser_state_takes_a_name_and_a_keyword() -> None:
    # Lark's contextual lexer reads a keyword as a NAME where only a name can come, and as
    # the keyword where the keyword can come; the fast parser reads a word as whatever the
    # grammar expects where it stands, which is the same only while no state takes both.
    keywords = set(_keywords())
    table = _lark().parser.parser.parser.parse_table
    for state, actions in table.states.items():
        if "NAME" in actions:
            assert not keywords & set(actions), state


def _tokens(text: str) -> list[tuple[str, str, int, int]]:
    lexer = Lexer(text, "f.ram")
    found = []
    while lexer.kind != END:
        found.append((lexer.kind, lexer.value, lexer.line, lexer.column))
        lexer.advance()
    return found


def test_tokens_and_positions() -> None:
    text = "topic /a.b: x/Y {f} @ -1.5e3Hz ±2 # c\n  node ~/p,"
    assert _tokens(text) == [
        ("NAME", "topic", 1, 1),
        ("FIELD_REF", "/a.b", 1, 7),
        (":", ":", 1, 11),
        ("NAME", "x/Y", 1, 13),
        ("{", "{", 1, 17),
        ("NAME", "f", 1, 18),
        ("}", "}", 1, 19),
        ("@", "@", 1, 21),
        ("NUMBER", "-1.5e3", 1, 23),
        ("NAME", "Hz", 1, 29),
        ("PLUS_MINUS", "±", 1, 32),
        ("NUMBER", "2", 1, 33),
        ("NAME", "node", 2, 3),
        ("NAME", "~/p", 2, 8),
        (",", ",", 2, 11),
    ]


def test_comments_are_lark_comment_tokens() -> None:
    lexer = Lexer("robot r # one\n# two\n", "f.ram")
    while lexer.kind != END:
        lexer.advance()
    assert [(str(t), t.line, t.column, t.end_column) for t in lexer.comments] == [
        ("# one", 1, 9, 14),
        ("# two", 2, 1, 6),
    ]


def test_a_token_read_again_in_context() -> None:
    lexer = Lexer("10.0.0.1:8080 x", "f.ram")
    assert (lexer.kind, lexer.value) == ("NUMBER", "10.0")
    lexer.read_as("ADDRESS")
    assert (lexer.kind, lexer.value) == ("ADDRESS", "10.0.0.1:8080")
    lexer.advance()
    assert (lexer.kind, lexer.value, lexer.column) == ("NAME", "x", 15)
    glued = Lexer("~/c.d", "f.ram")
    glued.read_as("~")
    glued.advance()
    assert (glued.kind, glued.value, glued.column) == ("FIELD_REF", "/c.d", 2)


@pytest.mark.parametrize("text", ["robot r\v", "robot €", "robot r\n  $"])
def test_what_no_terminal_reads_is_left_to_lark(text: str) -> None:
    with pytest.raises(Bail):
        _tokens(text)
