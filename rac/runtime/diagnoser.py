"""The diagnosis node's logic (§6.3, §6.4): Algorithm 10's collection, then minimal diagnoses.

Observations are merged into Θ as they come (:class:`rac.observe.ObservationSet`); on each
tick the engine diagnoses Θ again if it or the model changed since the last tick.  A
transport ticks at its publication rate, and sooner when Θ changes (:attr:`pending`), so
that a new fault does not wait for the next period.  The model
can be replaced at run time (§6.3's model server permits changes): Θ is kept and the next
tick diagnoses it against the new theory.
"""

from __future__ import annotations

from dataclasses import dataclass

from rac.diagnosis import DiagnosisResult, Theory, diagnose
from rac.diagnosis.theory import known_atoms
from rac.logic import NEG_PREFIX, Atom
from rac.observe import ObservationSet, Verdict
from rac.runtime.status import Row, diagnosis_rows, summary_row


@dataclass(frozen=True, slots=True)
class Tick:
    result: DiagnosisResult
    rows: tuple[Row, ...]  # for /diagnosis
    summary: Row  # for /diagnostics
    changed: bool  # the diagnoses differ from the last tick's


class Diagnoser:
    def __init__(self, theory: Theory, robot: str, node: str, max_card: int | None = None) -> None:
        self.robot, self.node, self.max_card = robot, node, max_card
        self.observations = ObservationSet()
        self.unknown: set[Atom] = set()  # atoms the model does not know (reported once)
        self._dirty = True
        self._last: DiagnosisResult | None = None
        self.load(theory)

    def load(self, theory: Theory) -> None:
        self.theory = theory
        self._known = known_atoms(theory)
        self._dirty = True

    def observe(self, verdict: Verdict) -> bool:
        """Θ ⊕ θ; True when Θ changed.  Atoms the model does not know are set aside."""
        atom = verdict.atom
        plain = Atom(atom.predicate.removeprefix(NEG_PREFIX), atom.args)
        if plain not in self._known and atom not in self._known:
            self.unknown.add(plain)
            return False
        changed = self.observations.add(verdict)
        self._dirty |= changed
        return changed

    @property
    def pending(self) -> bool:
        """Θ or the model changed since the last tick."""
        return self._dirty

    def tick(self) -> Tick:
        result = self._last
        if result is None or self._dirty:
            result = diagnose(self.theory, self.observations.literals(), self.max_card)
            self._dirty = False
        changed = self._last is None or result.diagnoses != self._last.diagnoses
        self._last = result
        return Tick(
            result,
            diagnosis_rows(result, self.robot),
            summary_row(self.node, self.robot, result, len(self.observations)),
            changed,
        )


def diagnosis_line(t: float, result: DiagnosisResult) -> str:
    if result.consistent:
        return f"t={t:.3f} diagnosis none (no fault)"
    if not result.diagnoses:
        return f"t={t:.3f} diagnosis impossible (the observations contradict the model)"
    shown = " | ".join("{" + ",".join(d) + "}" for d in result.diagnoses)
    return f"t={t:.3f} diagnosis {shown}"
