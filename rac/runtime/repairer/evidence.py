"""Which node to repair first: the evidence of a crash, and what a repair sets settling.

Several minimal diagnoses can stand at once, and the ``minimal`` strategy repairs every
component of the smallest ones.  On a chain of nodes (a player, then relays, each feeding
the next) that is wrong in two moments a live robot goes through at every crash:

- **While a crash shows.**  A killed node's own observer says ``not_running`` within a
  sample or two, and the frequency observers of every topic below it turn ``not_ok`` about
  a second later; until the upstream topics' verdicts are in (an observer host late, a
  topic still in its first window), each node above the silent topics explains them as
  well as the killed one, and the first of them by name, the chain's source, was restarted
  first.  A node the observations show not running is a fact, not a hypothesis: it is
  restarted first, alone (:func:`crashed`), and whatever the diagnosis still names once it
  runs again is a new fault, planned for as usual.
- **While a repair settles.**  A restarted node's output comes back at once, but each node
  below it receives again only once it has connected to the new process (the master tells
  it, then it connects), and each frequency observer turns ``ok`` only after its window has
  refilled: for a moment the first node below the repaired one explains the topics still
  silent.  During a repair's verification, a diagnosis that names only nodes downstream of
  what the repair touched (:func:`downstream`) is the repair settling, not a new fault; if
  it still stands when the verification times out, it is planned for as any diagnosis.
"""

from __future__ import annotations

from collections.abc import Iterable

from rac.diagnosis import Theory
from rac.logic import Atom
from rac.observe import ObservationSet


def crashed(diagnoses: Iterable[tuple[str, ...]], observations: ObservationSet) -> tuple[str, ...]:
    """The components of ``diagnoses`` that Θ shows not running (sorted)."""
    named = {c for d in diagnoses for c in d}
    return tuple(sorted(c for c in named if observations.polarity(Atom("running", (c,))) is False))


def downstream(theory: Theory, components: Iterable[str]) -> frozenset[str]:
    """Every component that reads, through the model's clauses, what ``components`` derive
    (directly or through others): the nodes below them in the topic graph."""
    produces: dict[str, set[Atom]] = {}  # component -> the atoms its clauses derive
    readers: dict[Atom, set[str]] = {}  # atom -> the components whose clauses read it
    for clause in theory.clauses:
        mine = [a.args[0] for a in clause.body if a.predicate == theory.nab and a.args]
        for c in mine:
            produces.setdefault(c, set()).add(clause.head)
        for atom in clause.body:
            if atom.predicate not in (theory.nab, theory.ab):
                readers.setdefault(atom, set()).update(mine)
    start = set(components)
    seen: set[str] = set()
    todo = list(start)
    while todo:
        c = todo.pop()
        for atom in produces.get(c, ()):
            for reader in readers.get(atom, ()):
                if reader not in seen and reader not in start:
                    seen.add(reader)
                    todo.append(reader)
    return frozenset(seen)
