"""The lexer of the fast ``.ram`` parser (:mod:`rac.fastparse`): text in, tokens out.

The terminals are those of ``rac/grammar/ram.lark``, the definition of the language; their
patterns are copied here and ``tests/test_ram_lexer.py`` holds them equal to what Lark reads
from the grammar.  One master pattern reads the next token wherever the parser stands:

- ``FIELD_REF`` before ``NAME``, as Lark orders them (the longer pattern first): a word with
  a dot is a field reference, one without is a name.  Keywords, units, message types and
  field names are words too; the parser checks each word against the terminal the grammar
  expects where it stands (a keyword by its text, ``MSG_TYPE``, ``FIELD`` and ``INT`` by
  their patterns), and a word that is not what is expected stops it.
- ``NUMBER``, ``PLUS_MINUS`` and the one-character punctuation of the grammar.
- whitespace (Lark's ``WS``) and comments, which are skipped; comments are kept as the
  ``COMMENT`` tokens Lark's callback collects.

Lark's lexer is contextual: it tries only the terminals its parser state accepts.  This one
reads the same tokens from every valid model the parser accepts, with two exceptions the
parser asks for by name (:meth:`Lexer.read_as`): an ``ADDRESS`` (``10.0.0.1``, ``fe80::1``)
reads as numbers and colons to the master pattern, and a ``~`` glued to the field reference
after it (``/a.b ~/c.d``) reads as one name; there the parser has the token read again.
Where the two lexers could differ otherwise (a keyword glued to the next word, as in
``publishes /a fromage``, which Lark reads as ``from age``), the tokens here are not what
the parser expects, and it hands the text to Lark (:class:`Bail`).
"""

from __future__ import annotations

import re

from lark import Token

# The grammar's terminals (rac/grammar/ram.lark), verbatim; tests/test_ram_lexer.py holds
# them equal to Lark's reading of the grammar.
TERMINALS = {
    "NAME": r"[A-Za-z_~\/][A-Za-z0-9_~\/\-]*",
    "FIELD_REF": (
        r"[A-Za-z_~\/][A-Za-z0-9_~\/\-]*\.[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*"
    ),
    "MSG_TYPE": r"[A-Za-z_][A-Za-z0-9_]*(\/[A-Za-z_][A-Za-z0-9_]*)+",
    "FIELD": r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*",
    "NUMBER": r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?",
    "INT": r"\d+",
    "ADDRESS": r"[A-Za-z0-9][A-Za-z0-9.:\-]*",
    "COMMENT": "#[^\n]*",  # a newline character, as Lark reads the grammar
}
# String terminals: the literal alternatives of each.
PLUS_MINUS = ("+-", "±")
TIME_UNITS = ("ms", "s")
MEM_UNIT_NAMES = ("GiB", "MiB", "KiB", "GB", "MB", "kB", "KB", "B")
CONTAINER_RUNTIMES = ("docker", "podman")
# The one-character anonymous terminals of the grammar ('~' is read as a NAME: see below).
PUNCTUATION = ";:{}@%,()"
# Lark's common.WS.
WHITESPACE = " \t\f\r\n"

# Kinds of token besides the terminal names above and the punctuation characters.
END = "END"


def _plain(pattern: str) -> str:
    """``pattern`` with its groups made non-capturing (the master pattern names its own)."""
    return re.sub(r"\((?!\?)", "(?:", pattern)


# Blanks before a token on its line are skipped in the same match; a newline is a token of
# its own to the loop in Lexer.advance, which counts lines.  '~' (relate's separator) is
# also the start of a NAME (``~/private``): where the parser expects the separator, it has
# the token read again (Lexer.read_as).
_MASTER = re.compile(
    r"[ \t\f\r]*(?:"
    r"(?P<NEWLINE>\n)"
    rf"|(?P<COMMENT>{TERMINALS['COMMENT']})"
    rf"|(?P<FIELD_REF>{_plain(TERMINALS['FIELD_REF'])})"
    rf"|(?P<NAME>{TERMINALS['NAME']})"
    rf"|(?P<NUMBER>{_plain(TERMINALS['NUMBER'])})"
    r"|(?P<PLUS_MINUS>\+-|±)"
    rf"|(?P<PUNCT>[{re.escape(PUNCTUATION)}])"
    r"|(?P<END>\Z))"
)
_ADDRESS = re.compile(TERMINALS["ADDRESS"])
_match = _MASTER.match


class Bail(Exception):
    """The fast parser cannot vouch for this input; parse it with Lark instead."""


class Lexer:
    """The tokens of one ``.ram`` text, one at a time.

    The current token is ``kind`` (a terminal name, a punctuation character or ``END``)
    and ``value``, at ``line`` and ``column`` (1-based; a token never spans lines).
    ``end_line`` and ``end_column`` are where the token consumed last ended (exclusive),
    which is where a rule that ended with it ends.
    """

    __slots__ = (
        "column",
        "comments",
        "end_column",
        "end_line",
        "kind",
        "line",
        "line_start",
        "path",
        "pos",
        "text",
        "value",
    )

    def __init__(self, text: str, path: str) -> None:
        self.text = text
        self.path = path
        self.pos = 0  # where the text after the current token begins
        self.line = 1
        self.line_start = 0  # index of the first character of the current line
        self.comments: list[Token] = []
        self.kind = END
        self.value = ""
        self.column = 1
        self.end_line = 1
        self.end_column = 1
        self.advance()

    def advance(self) -> None:
        """Consume the current token and read the next one (``Bail`` if none can be read)."""
        self.end_line = self.line
        self.end_column = self.column + len(self.value)
        text = self.text
        while True:
            m = _match(text, self.pos)
            if m is None:
                raise Bail
            kind = m.lastgroup
            self.pos = end = m.end()
            if kind == "NEWLINE":
                self.line += 1
                self.line_start = end
                continue
            value = m[kind]  # type: ignore[index]
            if kind == "COMMENT":
                self._comment(end - len(value), end)
                continue
            self.kind = value if kind == "PUNCT" else kind  # type: ignore[assignment]
            self.value = value
            self.column = end - len(value) - self.line_start + 1
            return

    def read_as(self, terminal: str) -> None:
        """Read the current token again as ``terminal``, where Lark's contextual lexer reads
        the same characters otherwise than the master pattern: an ``ADDRESS``, or the ``~``
        between two sides of a relation that a glued field reference follows
        (``/a.b ~/c.d``: the master pattern reads ``~/c.d`` as one field reference)."""
        start = self.pos - len(self.value)
        if terminal == "ADDRESS":
            m = _ADDRESS.match(self.text, start)
            if m is None:
                raise Bail
            self.kind, self.value, self.pos = terminal, m.group(), m.end()
        elif terminal == "~" and self.value.startswith("~"):
            self.kind, self.value, self.pos = "~", "~", start + 1
        else:
            raise Bail

    def _comment(self, start: int, end: int) -> None:
        column = start - self.line_start + 1
        self.comments.append(
            Token(
                "COMMENT",
                self.text[start:end],
                start_pos=start,
                line=self.line,
                column=column,
                end_line=self.line,
                end_column=column + end - start,
                end_pos=end,
            )
        )
