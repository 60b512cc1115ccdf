"""Fault modes: what the observers see when a component fails in a given way.

The diagnosis theory knows one thing about a faulty component: it is abnormal.  How it
fails decides which of its clauses stop holding, and so what the observers report:

- ``crash``: the component stops; every clause that names it fails (a node's topics,
  ``running``, its limits and reports; a device's ``on`` and everything that needs it).
- ``output``: a node runs but its outputs are wrong: its publications, the loop rules through
  them and its related pairs fail; ``running``, its limits and its reports still hold.
- ``silent-hardware``: a device is dead while the board still shows it powered: ``on(h)``
  holds, its reports fail, and every topic of the nodes that drive it goes bad.

The truth model is the RBM with each ``NAB(c)`` split by the role it plays in the clause
(``c@on``, ``c@out``, ``c@run``, ``c@rep``); a fault makes some of those roles abnormal and
its observations are what the split clauses derive.  Only ``.ram``/``.json`` models have
modes other than ``crash``: a hand-written model.yaml does not say what its clauses are.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from rac.diagnosis.engine import Index
from rac.diagnosis.theory import Literal, Theory
from rac.errors import Diagnostic, RacError
from rac.ir import Model
from rac.logic import NAB, Atom, Clause, mangle
from rac.passes import rbm
from rac.passes.loops import loop_clauses

MODES = ("crash", "output", "silent-hardware")

# The role of NAB(c) in each clause group; "diagnostics" is decided per atom below.
_ROLE = {
    rbm._hardware_clauses: "on",
    rbm._publication_clauses: "out",
    loop_clauses: "out",
    rbm._node_clauses: "run",
    rbm._limit_clauses: "run",
    rbm._pair_clauses: "out",
}


@dataclass(frozen=True, slots=True)
class Truth:
    """The role-split RBM of one model, compiled once, and what each mode breaks."""

    model: Model
    index: Index
    props: tuple[Atom, ...]
    neg_prefix: str
    nodes: frozenset[str]  # mangled
    publishers: frozenset[str]  # mangled nodes that publish a topic
    drivers: dict[str, tuple[str, ...]]  # mangled hardware -> mangled driving nodes
    roles: frozenset[str]

    def applies(self, mode: str, component: str) -> bool:
        """Whether ``mode`` is a way ``component`` (mangled) can fail."""
        if mode == "output":  # a node without outputs cannot get them wrong
            return component in self.publishers
        if mode == "silent-hardware":
            return component not in self.nodes
        return True

    def broken(self, mode: str, faults: Iterable[str]) -> frozenset[str]:
        roles: set[str] = set()
        for c in faults:
            if mode == "crash":
                roles.update(f"{c}@{r}" for r in ("on", "out", "run", "rep"))
            elif mode == "output":
                roles.add(f"{c}@out")
            else:
                roles.add(f"{c}@out")
                roles.update(f"{d}@out" for d in self.drivers.get(c, ()))
        return frozenset(roles & self.roles)

    def observe(self, mode: str, faults: Sequence[str]) -> tuple[Literal, ...]:
        """The observers' report with ``faults`` failing in ``mode`` and all else healthy."""
        index = self.index
        bad = self.broken(mode, faults)
        base, _ = index.base(())
        derived = index.run(base, index.assignment(bad, strong=False), stop=False).why
        out = []
        for atom in self.props:
            i = index.atom_id(atom)
            holds = i is not None and (bool(base.true[i]) or i in derived)
            out.append(Literal(atom, holds, self.neg_prefix))
        return tuple(out)


def _split(clause: Clause, role: str | None, hardware: frozenset[str]) -> Clause:
    body = []
    for atom in clause.body:
        if atom.predicate != NAB:
            body.append(atom)
            continue
        c = atom.args[0]
        r = role if role is not None else ("out" if c in hardware else "rep")
        body.append(Atom(NAB, (f"{c}@{r}",)))
    return Clause(tuple(body), clause.head)


def truth_model(theory: Theory) -> Truth:
    """The truth model of a theory compiled from a ``.ram``/``.json`` model."""
    model = theory.model
    if model is None:
        raise RacError(
            [
                Diagnostic(
                    "RAC060",
                    "fault modes other than 'crash' need a .ram or .json model",
                    hint="a model.yaml does not say what its clauses are: use --mode crash",
                )
            ]
        )
    cached = model._memo.get("truth")
    if isinstance(cached, Truth):
        return cached
    hardware = frozenset(mangle(h.name.value) for h in model.hardware)
    clauses: list[Clause] = []
    seen: set[tuple[frozenset[Atom], Atom]] = set()
    for group in rbm.GROUPS:
        for clause in group(model):
            key = (frozenset(clause.body), clause.head)
            if key in seen:
                continue
            seen.add(key)
            clauses.append(_split(clause, _ROLE.get(group), hardware))
    roles = sorted({a.args[0] for c in clauses for a in c.body if a.predicate == NAB})
    split = Theory(tuple(clauses), theory.props, tuple(roles))
    drivers: dict[str, list[str]] = {}
    for node in model.nodes:
        for h in node.drives:
            drivers.setdefault(mangle(h.value), []).append(mangle(node.name.value))
    truth = Truth(
        model=model,
        index=Index(split),
        props=theory.props,
        neg_prefix=theory.neg_prefix,
        nodes=frozenset(mangle(n.name.value) for n in model.nodes),
        publishers=frozenset(mangle(n.name.value) for n in model.nodes if n.publishes),
        drivers={h: tuple(ns) for h, ns in drivers.items()},
        roles=frozenset(roles),
    )
    model._memo["truth"] = truth
    return truth


def check_mode(theory: Theory, mode: str, faults: Sequence[str]) -> None:
    """RAC061 when a component cannot fail in ``mode`` (a device has no output mode...)."""
    if mode == "crash":
        return
    truth = truth_model(theory)
    wrong = [c for c in faults if not truth.applies(mode, c)]
    if wrong:
        kind = "nodes that publish" if mode == "output" else "hardware"
        raise RacError(
            [
                Diagnostic(
                    "RAC061",
                    f"'{c}' cannot fail in mode '{mode}'",
                    hint=f"mode '{mode}' applies to {kind} only",
                )
                for c in wrong
            ]
        )


def observe(theory: Theory, mode: str, faults: Sequence[str]) -> tuple[Literal, ...] | None:
    """The observations of ``faults`` in ``mode``; None for ``crash`` (the theory's own)."""
    if mode == "crash" and theory.model is None:
        return None
    return truth_model(theory).observe(mode, faults)
