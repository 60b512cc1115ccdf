"""Observation collection (§6.4.1, Algorithm 10): the consistent observation set Θ_OBS.

Adding a literal that is already in the set changes nothing (line 1); otherwise its
opposite leaves the set (lines 2-10) and the literal enters it (line 11).  An atom written
with the negative prefix (``not_ok(x)``) is read as the negation of ``ok(x)``.
"""

from __future__ import annotations

from rac.diagnosis.theory import Literal
from rac.logic import NEG_PREFIX, Atom
from rac.observe.events import Verdict


class ObservationSet:
    def __init__(self) -> None:
        self._polarity: dict[Atom, bool] = {}

    def add(self, v: Verdict) -> bool:
        """Θ ⊕ v; True when Θ changed."""
        atom, positive = v.atom, v.positive
        if atom.predicate.startswith(NEG_PREFIX):
            atom, positive = Atom(atom.predicate.removeprefix(NEG_PREFIX), atom.args), not positive
        if self._polarity.get(atom) is positive:
            return False
        self._polarity[atom] = positive  # replaces the opposite literal, if any
        return True

    def discard(self, atom: Atom) -> bool:
        """Θ without either literal of ``atom`` (its verdict is withdrawn: unknown)."""
        if atom.predicate.startswith(NEG_PREFIX):
            atom = Atom(atom.predicate.removeprefix(NEG_PREFIX), atom.args)
        return self._polarity.pop(atom, None) is not None

    def polarity(self, atom: Atom) -> bool | None:
        """Whether Θ holds ``atom`` (True), its negation (False), or neither (None)."""
        return self._polarity.get(atom)

    def literals(self) -> tuple[Literal, ...]:
        found = (Literal(atom, positive) for atom, positive in self._polarity.items())
        return tuple(sorted(found, key=str))

    def __len__(self) -> int:
        return len(self._polarity)
