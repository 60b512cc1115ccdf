"""Fault injection: predict what the observers would report, then diagnose it.

With the components ``faults`` abnormal and every other one normal, an observable atom p
holds iff the clauses derive it; otherwise its negation ``not_p`` is observed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from rac.diagnosis.modes import check_mode, observe, truth_model
from rac.diagnosis.result import DiagnosisResult, compile_theory, diagnose
from rac.diagnosis.theory import Literal, Theory
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.logic import FALSE, Atom


@dataclass(frozen=True, slots=True)
class Simulation:
    faults: tuple[str, ...]  # the injected set, sorted
    observations: tuple[Literal, ...]
    result: DiagnosisResult
    mode: str = "crash"  # how the faults fail (rac.diagnosis.modes)

    @property
    def detected(self) -> bool:
        """The observations contradict the all-normal assumption."""
        return not self.result.consistent

    @property
    def found(self) -> bool:
        """The injected fault set is one of the minimal diagnoses."""
        return self.faults in self.result.diagnoses

    @property
    def isolated(self) -> bool:
        """The injected fault set is the only minimal diagnosis."""
        return self.result.diagnoses == (self.faults,)


def check_components(theory: Theory, names: Sequence[str]) -> tuple[str, ...]:
    """The names, sorted and unique; RacError RAC042 (with did-you-mean) for unknown ones."""
    known = set(theory.components)
    errors = [_unknown_component(theory, name) for name in names if name not in known]
    if errors:
        raise RacError(errors)
    return tuple(sorted(set(names)))


def _unknown_component(theory: Theory, name: str) -> Diagnostic:
    """RAC042; fixed hardware is no component, its driver stands for it (Algorithm 9)."""
    model = theory.model
    fixed = model is not None and any(
        h.name.value == name and not h.switchable for h in model.hardware
    )
    if model is not None and fixed:
        drivers = sorted(n.name.value for n in model.nodes if name in {d.value for d in n.drives})
        if drivers:
            shown = " and ".join(drivers)
            message = (
                f"'{name}' is fixed hardware, so its faults show as faults of its driver"
                f"{'s' if len(drivers) > 1 else ''} {shown}"
            )
            return Diagnostic("RAC042", message, hint=f"inject a fault of {drivers[0]}")
        return Diagnostic("RAC042", f"'{name}' is fixed hardware that no node drives")
    known = theory.components
    hint = did_you_mean(name, known) or f"components: {', '.join(known)}"
    return Diagnostic("RAC042", f"unknown component '{name}'", hint=hint)


def observable(theory: Theory) -> tuple[Atom, ...]:
    """The props; for a hand-written model without props, every non-assumption rule head."""
    if theory.props:
        return theory.props
    heads = (c.head for c in theory.clauses)
    return tuple(
        dict.fromkeys(
            Atom(h.predicate.removeprefix(theory.neg_prefix), h.args)
            for h in heads
            if not theory.is_assumption(h) and h != Atom(FALSE)
        )
    )


def predict(theory: Theory, faults: Sequence[str]) -> tuple[Literal, ...]:
    """What the observers would report with ``faults`` abnormal and the rest normal."""
    bad = frozenset(check_components(theory, faults))
    index = compile_theory(theory)
    base, _ = index.base(())
    derived = index.run(base, index.assignment(bad, strong=True), stop=False).why
    observations = []
    for atom in observable(theory):
        i = index.atom_id(atom)
        holds = i is not None and (bool(base.true[i]) or i in derived)
        observations.append(Literal(atom, holds, theory.neg_prefix))
    return tuple(observations)


def simulate(
    theory: Theory, faults: Sequence[str], max_card: int | None = None, mode: str = "crash"
) -> Simulation:
    """Inject ``faults`` failing in ``mode`` (crash, output, silent-hardware) and diagnose."""
    injected = check_components(theory, faults)
    check_mode(theory, mode, injected)
    observations = predict(theory, injected) if mode == "crash" else observe(theory, mode, injected)
    assert observations is not None
    return Simulation(injected, observations, diagnose(theory, observations, max_card), mode)


def all_single_faults(
    theory: Theory, max_card: int | None = None, mode: str = "crash"
) -> tuple[Simulation, ...]:
    """One simulation per component that can fail in ``mode``."""
    if mode == "crash":
        comps = theory.components
    else:
        truth = truth_model(theory)
        comps = tuple(c for c in theory.components if truth.applies(mode, c))
    return tuple(simulate(theory, (c,), max_card, mode) for c in comps)


def ambiguity_groups(simulations: Sequence[Simulation]) -> tuple[tuple[str, ...], ...]:
    """Components the model cannot tell apart from their single-fault symptoms.

    c and d are linked when {d} is a candidate diagnosis for c's injected fault (or the
    reverse); a group is a connected set of two or more linked components.
    """
    parent: dict[str, str] = {}

    def root(c: str) -> str:
        while parent.get(c, c) != c:
            c = parent[c]
        return c

    for sim in simulations:
        if len(sim.faults) != 1:
            continue
        for candidate in sim.result.diagnoses:
            if len(candidate) == 1 and candidate != sim.faults:
                a, b = sorted((root(sim.faults[0]), root(candidate[0])))
                if a != b:
                    parent[b] = a
    groups: dict[str, list[str]] = {}
    for c in {c for sim in simulations for c in sim.faults} | set(parent):
        groups.setdefault(root(c), []).append(c)
    return tuple(sorted(tuple(sorted(g)) for g in groups.values() if len(g) > 1))
