"""Atoms and Horn clauses shared by the compiler, the model server file and the engine."""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

AB = "AB"
NAB = "NAB"
NEG_PREFIX = "not_"
FALSE = "false"


@functools.lru_cache(maxsize=1 << 16)  # a large model mangles each name many times
def mangle(name: str) -> str:
    """Turn a model name into an atom argument (docs/spec.md).

    ``/robot1/scan`` -> ``robot1_scan``; ``twist.twist.angular.z`` -> ``twist_twist_angular_z``.
    """
    return name.removeprefix("/").replace("/", "_").replace(".", "_").replace("-", "_")


INTEGRAL_PREFIX = "I_"


def integral_arg(field: str) -> str:
    """The atom argument of an integrated field: ``twist.twist.angular.z`` (in ``I(...)``)
    -> ``I_twist_twist_angular_z``."""
    return INTEGRAL_PREFIX + mangle(field)


@dataclass(frozen=True, slots=True, order=True)
class Atom:
    predicate: str
    args: tuple[str, ...] = ()

    def __str__(self) -> str:
        if not self.args:
            return self.predicate
        return f"{self.predicate}({','.join(self.args)})"


@dataclass(frozen=True, slots=True)
class Clause:
    """``body₁, body₂, … -> head``; an empty body is a fact, head ``false`` a constraint."""

    body: tuple[Atom, ...]
    head: Atom

    def __str__(self) -> str:
        if not self.body:
            return f"-> {self.head}"
        return f"{', '.join(str(a) for a in self.body)} -> {self.head}"


# Linear time on any text: each pattern is a single character class repeated, matched at a
# known position, and the rest is plain string work (no backtracking over untrusted text).
_PREDICATE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_ARGUMENT = re.compile(r"[A-Za-z0-9_]+")
# The common layout, ``pred`` or ``pred(a,b)`` with no blanks, in one match (a model file
# holds hundreds of thousands of atoms); anything else takes the general path below.
# Its pattern is shared by the readers that match many atoms in one pass (two groups:
# the predicate, the arguments joined by ',').
COMPACT_ATOM = r"([A-Za-z_][A-Za-z0-9_]*)(?:\(([A-Za-z0-9_]+(?:,[A-Za-z0-9_]+)*)\))?"
_COMPACT = re.compile(COMPACT_ATOM)


def parse_atom(text: str) -> Atom:
    """Parse ``ok(pose)``, ``ok(n, cpu)`` or a bare proposition such as ``false``."""
    stripped = text.strip()
    compact = _COMPACT.fullmatch(stripped)
    if compact is not None:
        args = compact.group(2)
        return Atom(compact.group(1), tuple(args.split(",")) if args else ())
    match = _PREDICATE.match(stripped)
    if match is None:
        raise ValueError(f"not an atom: {_shown(text)}")
    pred, rest = match.group(), stripped[match.end() :].lstrip()
    if not rest:
        return Atom(pred)
    if rest[0] != "(" or rest[-1] != ")" or "(" in rest[1:] or ")" in rest[:-1]:
        raise ValueError(f"not an atom: {_shown(text)}")
    parts = tuple(a.strip() for a in rest[1:-1].split(","))
    if any(_ARGUMENT.fullmatch(p) is None for p in parts):
        raise ValueError(f"not an atom: {_shown(text)}")
    return Atom(pred, parts)


def _shown(text: str) -> str:
    """``text`` quoted for a message, cut short when it is long."""
    return repr(text) if len(text) <= 80 else repr(text[:80]) + f"… ({len(text):,} characters)"


def split_body(text: str) -> list[str]:
    """Split ``NAB(a), ok(b,c)`` at the commas between atoms, not inside them."""
    parts: list[str] = []
    depth, start = 0, 0
    for i, ch in enumerate(text):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    stripped = [p.strip() for p in parts]
    if stripped == [""]:
        return []  # an empty body: a fact
    if "" in stripped:
        raise ValueError(f"an empty atom between commas: {_shown(text)}")
    return stripped


def parse_clause(text: str) -> Clause:
    """Parse ``A, B -> C`` (the model server's rule syntax)."""
    body_text, arrow, head_text = text.partition("->")
    if not arrow:
        raise ValueError(f"a rule needs '->': {_shown(text)}")
    body = tuple(parse_atom(a) for a in split_body(body_text))
    return Clause(body, parse_atom(head_text))
