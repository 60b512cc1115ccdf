"""Observation files: one literal per line (docs/spec.md#observations)."""

from __future__ import annotations

import re
from collections.abc import Container, Sequence

from rac.diagnosis.result import compile_theory
from rac.diagnosis.theory import Literal, Theory, collect, literal_at
from rac.errors import Diagnostic, RacError
from rac.load.files import read_text
from rac.load.kinds import OBSERVATIONS, check_kind
from rac.logic import COMPACT_ATOM, Atom
from rac.perf import paused_gc

# What --obs and --obs-file gave, in command-line order: ("obs", literal) or ("obs_file", path).
Sources = Sequence[tuple[str, str]] | None

# ``ok(x)``, ``not ok(x)`` or ``not_ok(x,y)`` alone on a line: the layout of a generated file.
_PLAIN_LITERAL = re.compile(rf" *(not +)?{COMPACT_ATOM} *")


# The same, one per line of a whole file, in one pass (a file of tens of thousands of lines).
_PLAIN_LINES = re.compile(rf"^{_PLAIN_LITERAL.pattern}$", re.MULTILINE)


def plain_lines(text: str) -> list[tuple[str, str, str]] | None:
    """Each line as (negation, predicate, arguments) when every line is a plain literal
    (``ok(x)``, ``not ok(x)``: the layout of a generated file); None when any is not
    (a comment, a blank line, another spelling), for the line-by-line reader."""
    found: list[tuple[str, str, str]] = _PLAIN_LINES.findall(text)
    lines = text.count("\n") + (not text.endswith("\n"))
    return found if len(found) == lines else None  # a match never spans two lines


def parse_observations(
    text: str, file: str, theory: Theory, known: Container[Atom] | None = None
) -> tuple[Literal, ...]:
    """An observation file: one literal per line, ``#`` starts a comment, blank lines skipped.

    Every bad line is reported (RAC040/RAC041) with ``file:line:column``.
    """
    with paused_gc():  # tens of thousands of literals, none cyclic (rac.perf)
        return _parse_observations(text, file, theory, known)


def _parse_observations(
    text: str, file: str, theory: Theory, known: Container[Atom] | None
) -> tuple[Literal, ...]:
    literals: list[Literal] = []
    errors: list[Diagnostic] = []
    if known is None:
        known = compile_theory(theory).known
    plain = _PLAIN_LITERAL.fullmatch
    prefix, assumptions = theory.neg_prefix, (theory.ab, theory.nab)
    for number, line in enumerate(text.splitlines(), start=1):
        found = plain(line)
        if found is not None:  # the common case, read in one match; the rest as below
            negation, pred, args = found.groups()
            atom = Atom(pred, tuple(args.split(",")) if args else ())
            if pred.startswith(prefix) or pred in assumptions or atom not in known:
                found = None  # the general path flips the prefix or says what is wrong
            else:
                literals.append(Literal(atom, negation is None, prefix))
                continue
        content = line.split("#", 1)[0]
        if not content.strip():
            continue
        column = len(content) - len(content.lstrip()) + 1
        try:
            literals.append(literal_at(content.strip(), theory, (file, number, column), known))
        except RacError as err:
            errors.extend(err.diagnostics)
    if errors:
        raise RacError(errors, text)
    return tuple(literals)


def read_observations(sources: Sources, theory: Theory) -> tuple[Literal, ...]:
    """Θ from ``('obs', literal)`` and ``('obs_file', path)`` pairs in command-line order
    (--obs and --obs-file; docs/spec.md#observations): later literals win."""
    literals: list[Literal] = []
    known = compile_theory(theory).known  # once: a look-up in the theory's clause index
    for kind, value in sources or ():
        if kind == "obs":
            literals.append(literal_at(value, theory, None, known))
        else:
            check_kind(value, OBSERVATIONS, "RAC004")
            literals.extend(parse_observations(read_text(value), value, theory, known))
    return collect(literals)


def read_observed_ids(sources: Sources, theory: Theory) -> list[int]:
    """:func:`read_observations` as atom numbers of the theory's index, for :func:`diagnose_ids`.

    A file of plain literal lines (what generators write) is read in one pass straight to
    atom numbers; anything else goes through the literal parser, with its diagnostics.
    """
    index = compile_theory(theory)
    known = index.known
    observed: list[int] = []
    for kind, value in sources or ():
        if kind == "obs":
            observed.append(index.literal_atom(literal_at(value, theory, None, known)))
            continue
        check_kind(value, OBSERVATIONS, "RAC004")
        text = read_text(value)
        lines = plain_lines(text)
        fast = index.plain_ids(lines) if lines is not None else None
        if fast is None:
            fast = index.observed_ids(parse_observations(text, value, theory, known))
        observed.extend(fast)
    return index.collect_ids(observed)
