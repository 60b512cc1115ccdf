"""derive_rbm: the robot behavioural model, docs/spec.md (Algorithm 9 generalised).

Clauses come out in the order of the groups of docs/spec.md, each group in
declaration order, without duplicates, so the output is stable and readable.  The loop
rule (``rac.passes.loops``) follows the publication clauses it completes.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator

from rac.ir import FieldRef, Model
from rac.logic import NAB, Atom, Clause, integral_arg, mangle
from rac.passes.loops import loop_clauses


# Atoms are immutable, and a model names each component and topic in many clauses:
# building each atom once saves a third of the pass on large models.
@functools.lru_cache(maxsize=1 << 16)
def nab(name: str) -> Atom:
    return Atom(NAB, (mangle(name),))


@functools.lru_cache(maxsize=1 << 16)
def ok(*names: str) -> Atom:
    return Atom("ok", tuple(mangle(n) for n in names))


def field_arg(ref: FieldRef) -> str:
    """A field's atom argument: ``twist_twist_angular_z``, or ``I_twist_twist_angular_z``
    for ``I(...)``."""
    return integral_arg(ref.field) if ref.integrated else mangle(ref.field)


def field_atom(predicate: str, a: FieldRef, b: FieldRef) -> Atom:
    """``matched(t1,f1,t2,f2)`` / ``equal(...)`` for a field pair."""
    return Atom(predicate, (mangle(a.topic), field_arg(a), mangle(b.topic), field_arg(b)))


def _unique(atoms: list[Atom]) -> tuple[Atom, ...]:
    return tuple(dict.fromkeys(atoms))


def _hardware_clauses(model: Model) -> Iterator[Clause]:
    for hw in model.hardware:
        if hw.switchable:
            yield Clause((nab(hw.name.value),), Atom("on", (mangle(hw.name.value),)))


def _publication_clauses(model: Model) -> Iterator[Clause]:
    switchable = {h.name.value for h in model.hardware if h.switchable}
    for node in model.nodes:
        hardware = [nab(h.value) for h in node.drives if h.value in switchable]
        for pub in node.publishes:
            inputs = [ok(i.value) for i in pub.affected_by]
            body = _unique([nab(node.name.value), *hardware, *inputs])
            yield Clause(body, ok(pub.topic.value))


def _node_clauses(model: Model) -> Iterator[Clause]:
    for node in model.nodes:
        yield Clause((nab(node.name.value),), Atom("running", (mangle(node.name.value),)))


def _limit_clauses(model: Model) -> Iterator[Clause]:
    for node in model.nodes:
        for prop in node.limits.declared:
            yield Clause((nab(node.name.value),), ok(node.name.value, prop))


def _diagnostics_clauses(model: Model) -> Iterator[Clause]:
    hardware = {h.name.value for h in model.hardware}
    for node in model.nodes:
        for device in node.diagnostics:
            body = [nab(node.name.value)]
            if device.value in hardware:
                body.append(nab(device.value))
            yield Clause(_unique(body), ok(device.value))


def _pair_clauses(model: Model) -> Iterator[Clause]:
    publishers = model.publishers()
    regular = {t.name.value for t in model.topics if t.regular}
    pairs = [("matched", r.a, r.b) for r in model.related]
    pairs += [("equal", i.a, i.b) for i in model.intervals]
    for predicate, a, b in pairs:
        observed = [ok(t) for t in (a.topic, b.topic) if t in regular]
        for n1 in publishers.get(a.topic, ()):
            for n2 in publishers.get(b.topic, ()):
                body = _unique([nab(n1), nab(n2), *observed])
                yield Clause(body, field_atom(predicate, a, b))


GROUPS = (
    _hardware_clauses,
    _publication_clauses,
    loop_clauses,  # 2b: the loop rule, after the publications it completes
    _node_clauses,
    _limit_clauses,
    _diagnostics_clauses,
    _pair_clauses,
)


def derive_rbm(model: Model) -> tuple[Clause, ...]:
    """The exact clause set of docs/spec.md for a validated model.

    Two clauses are the same when their bodies hold the same atoms: the related pair
    (τ.f1, τ.f2) with publishers n1 and n2 yields NAB(n1), NAB(n2) and NAB(n2), NAB(n1).
    """
    seen: set[tuple[frozenset[Atom], Atom]] = set()
    clauses: list[Clause] = []
    for group in GROUPS:
        for clause in group(model):
            key = (frozenset(clause.body), clause.head)
            if key not in seen:
                seen.add(key)
                clauses.append(clause)
    return tuple(clauses)


def components(clauses: tuple[Clause, ...]) -> tuple[str, ...]:
    """COMPS: the arguments of NAB(...) in the clauses, sorted."""
    return tuple(sorted({a.args[0] for c in clauses for a in c.body if a.predicate == NAB}))
