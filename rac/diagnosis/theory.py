"""Diagnosis theories and observation literals (docs/spec.md).

A :class:`Theory` is what the engine reasons over, whichever file it came from: the
compiled RBM of a ``.ram``/``.json`` model, or the rules of a model-server ``model.yaml``
(generated or hand-written, with fault-mode rules and ``false`` constraints).
"""

from __future__ import annotations

import re
from collections.abc import Container, Iterable
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING

from rac.errors import Diagnostic, RacError, Span, did_you_mean
from rac.logic import AB, FALSE, NAB, NEG_PREFIX, Atom, Clause, mangle, parse_atom
from rac.perf import ByIdentity

if TYPE_CHECKING:  # the compiler loads only for .ram/.json models
    from rac.ir import Model
    from rac.pipeline import Compiled


Key = tuple[str, tuple[str, ...]]  # an atom as (predicate, args)


@dataclass(frozen=True, slots=True)
class ClauseTable:
    """A theory's clauses and props as atom numbers, from a reader that numbered them anyway.

    Atoms are numbered in the order the engine's index numbers them itself (every clause's
    head, then every body, then the props), so an index built from the table is the index
    built from the clauses, without looking every atom up again.  It describes exactly the
    ``clauses`` and ``props`` tuples it was made with; the index checks that by identity.
    """

    clauses: tuple[Clause, ...]
    props: tuple[Atom, ...]
    # (predicate, args) -> atom number, in the order of the numbers
    ids: MappingProxyType[Key, int] = field(compare=False)
    heads: tuple[int, ...]
    bodies: tuple[tuple[int, ...], ...]  # each body without repeated atoms
    # component -> the number of its NAB atom, for the components whose NAB occurs
    nab: MappingProxyType[str, int] = field(compare=False)


@dataclass(frozen=True, slots=True)
class Theory:
    """A diagnosis model: Horn clauses, observable atoms and the components."""

    clauses: tuple[Clause, ...]
    props: tuple[Atom, ...]
    components: tuple[str, ...]
    ab: str = AB
    nab: str = NAB
    neg_prefix: str = NEG_PREFIX
    model: Model | None = None
    # the robot's name from the header line racc writes atop a model.yaml (None: no header)
    robot: str | None = field(default=None, compare=False)
    # the clauses already numbered (rac.load.model_yaml): a speed-up, never a meaning
    table: ClauseTable | None = field(default=None, compare=False, repr=False)

    def negate(self, atom: Atom) -> Atom:
        """The propositional atom standing for ¬atom (``ok(x)`` <-> ``not_ok(x)``)."""
        if atom.predicate.startswith(self.neg_prefix):
            return Atom(atom.predicate.removeprefix(self.neg_prefix), atom.args)
        return Atom(self.neg_prefix + atom.predicate, atom.args)

    def is_assumption(self, atom: Atom) -> bool:
        return atom.predicate in (self.ab, self.nab)


def theory_of(compiled: Compiled) -> Theory:
    """The diagnosis theory of a compiled model: its clauses, observables and components."""
    return Theory(
        clauses=compiled.rbm,
        props=compiled.props,
        components=compiled.components,
        model=compiled.model,
    )


@dataclass(frozen=True, slots=True)
class Literal:
    """An observation: ``atom`` or its negation; ``atom`` never carries the prefix."""

    atom: Atom
    positive: bool
    neg_prefix: str = NEG_PREFIX

    def __str__(self) -> str:
        return str(self.atom) if self.positive else f"{self.neg_prefix}{self.atom}"

    def negated(self) -> Literal:
        return Literal(self.atom, not self.positive, self.neg_prefix)


def components_of(clauses: Iterable[Clause], ab: str = AB, nab: str = NAB) -> tuple[str, ...]:
    """COMPS: the arguments of AB(...) and NAB(...) anywhere in the clauses, sorted."""
    found: set[str] = set()
    for clause in clauses:
        for atom in (*clause.body, clause.head):
            if atom.predicate in (ab, nab) and len(atom.args) == 1:
                found.add(atom.args[0])
    return tuple(sorted(found))


def known_atoms(theory: Theory) -> frozenset[Atom]:
    """Positive forms of every atom the theory mentions (props and rules, not AB/NAB)."""
    atoms: set[Atom] = set(theory.props)
    for clause in theory.clauses:
        atoms.update(clause.body)
        atoms.add(clause.head)
    positive = {_strip(a, theory.neg_prefix) for a in atoms if not theory.is_assumption(a)}
    positive.discard(Atom(FALSE))
    return frozenset(positive)


def _strip(atom: Atom, prefix: str) -> Atom:
    return Atom(atom.predicate.removeprefix(prefix), atom.args)


_NEGATIONS = re.compile(r"^\s*(?:not\s+|¬\s*|~\s*|!\s*)")


def parse_literal(text: str, theory: Theory) -> Literal:
    """``ok(pose)``, ``not ok(pose)``, ``not_ok(pose)`` or ``¬ok(pose)`` as a literal.

    RacError RAC041 when it is not a literal, RAC040 when the theory does not know the atom.
    The theory's atoms are gathered once per theory (the last few are kept), not once per
    call: a call per observation stays linear in the observations.
    """
    return literal_at(text, theory, None, _known_of(theory))


# known_atoms of the last few theories (parse_literal is called once per observation)
# (a lambda: known_atoms is looked up when called, as a test that counts its calls wants)
_known_of: ByIdentity[Theory, frozenset[Atom]] = ByIdentity(lambda t: known_atoms(t))


def literal_at(
    text: str,
    theory: Theory,
    where: tuple[str, int, int] | None,
    known: Container[Atom] | None = None,
) -> Literal:
    """:func:`parse_literal`, with ``(file, line, column)`` for the diagnostic span.

    ``known`` is :func:`known_atoms` of ``theory`` (or the clause index's ``known``), when
    the caller has it: a file of literals computes it once, not once per line.
    """
    span = None
    if where is not None:
        file, line, column = where
        span = Span(file, line, column, line, column + max(1, len(text.strip())))
    negation = _NEGATIONS.match(text)
    positive = negation is None
    body = text[negation.end() :] if negation else text
    mangled_from = None
    atom: Atom | None
    try:
        atom = parse_atom(body)
    except ValueError:
        atom = _with_ros_names(body)  # ok(/odom), ok(imu/data): mangle as the compiler does
        mangled_from = body.strip()
    if atom is None:
        raise RacError(
            [
                Diagnostic(
                    "RAC041",
                    f"malformed literal {text.strip()!r}",
                    span,
                    hint="write an atom such as 'ok(pose)', 'not ok(pose)' or 'not_ok(pose)'",
                )
            ]
        ) from None
    if known is None:
        known = known_atoms(theory)
    if theory.is_assumption(atom):
        raise RacError(
            [
                Diagnostic(
                    "RAC040",
                    f"'{atom}' is an assumption about a component, not an observation",
                    span,
                    hint="observe what the observers report, e.g. 'running(n)' or 'ok(topic)'",
                )
            ]
        )
    stripped = _strip(atom, theory.neg_prefix)
    if atom.predicate.startswith(theory.neg_prefix) and stripped in known:
        atom, positive = stripped, not positive
    if atom not in known:
        names = [str(a) for a in (known if isinstance(known, frozenset) else known_atoms(theory))]
        hint = did_you_mean(str(atom), names)
        if hint is None and theory.props:
            shown = ", ".join(str(a) for a in theory.props[:5])
            hint = f"observable atoms include {shown}"
        what = f"'{atom}' (from '{mangled_from}')" if mangled_from else f"'{atom}'"
        raise RacError(
            [Diagnostic("RAC040", f"unknown atom {what} in an observation", span, hint=hint)]
        )
    return Literal(atom, positive, theory.neg_prefix)


_ROS_ATOM = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*\(([^()]*)\)\s*")


def _with_ros_names(text: str) -> Atom | None:
    """``ok(/imu/data)`` as ``ok(imu_data)``: ROS names in an atom, mangled; None if no atom."""
    match = _ROS_ATOM.fullmatch(text)
    if match is None:
        return None
    args = ",".join(mangle(a.strip()) for a in match.group(2).split(","))
    try:
        return parse_atom(f"{match.group(1)}({args})")
    except ValueError:
        return None


def collect(literals: Iterable[Literal]) -> tuple[Literal, ...]:
    """Θ ⊕ θ for each literal in turn (Algorithm 10): a literal replaces its opposite."""
    held: dict[Atom, Literal] = {}
    for literal in literals:
        held.pop(literal.atom, None)  # later wins; keep insertion order of the latest
        held[literal.atom] = literal
    return tuple(held.values())
