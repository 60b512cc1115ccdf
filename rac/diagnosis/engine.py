"""The propositional core: a clause index compiled once per theory, and LTUR propagation.

Every atom, ``not_p`` included, is its own proposition; a state is contradictory when it holds
``p`` and ``not_p``, ``AB(c)`` and ``NAB(c)``, or ``false``.  Consistency is decided by
counter-based unit propagation (Dowling-Gallier / LTUR): each clause keeps the number of its
body atoms not yet true, so every clause is touched at most once per body atom, which is linear
in the size of the clause set.

Propagation always starts from a :class:`Base`, the closure of the facts and the observations
Θ without any assumption.  A run adds assumption atoms on top of it and keeps its own changes
in dictionaries, so a check that only touches a few clauses (a candidate conflict) costs only
those clauses, not the whole model.
"""

from __future__ import annotations

from collections import ChainMap
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from rac.diagnosis.theory import Literal, Theory
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.logic import FALSE, Atom

ASSUMED = -1  # justification of an atom that was assumed, not derived
Key = tuple[str, tuple[str, ...]]  # an atom as (predicate, args)


@dataclass(frozen=True, slots=True)
class Base:
    """The closure of facts ∪ Θ: which atoms hold and each clause's count of missing atoms."""

    true: bytearray
    missing: list[int]


@dataclass(frozen=True, slots=True)
class Run:
    """The outcome of propagating assumptions on a base."""

    clash: tuple[int, ...]  # the contradictory atoms, () when consistent
    why: Mapping[int, int]  # atom made true beyond the base -> its clause (or ASSUMED)


@dataclass(frozen=True, slots=True)
class Full:
    """The closure of a base with every component assumed normal, kept for incremental checks."""

    true: bytearray
    missing: list[int]
    why: dict[int, int]
    clashes: tuple[tuple[int, ...], ...]  # every contradiction it holds


class Index:
    """The clause set of a theory as integer arrays, built once and reused for every check."""

    def __init__(self, theory: Theory) -> None:
        self.theory = theory
        # Atoms are keyed by (predicate, args): tuple hashing runs in C, Atom's in Python,
        # which matters at 100,000 atoms.
        self.ids: dict[Key, int] = {}
        self.keys: list[Key] = []
        heads = [self._intern(c.head.predicate, c.head.args) for c in theory.clauses]
        bodies = [
            tuple(dict.fromkeys([self._intern(a.predicate, a.args) for a in c.body]))
            for c in theory.clauses
        ]
        for atom in theory.props:
            self._intern(atom.predicate, atom.args)
        self.nab_id = {c: self._intern(theory.nab, (c,)) for c in theory.components}
        self.ab_id = {c: self._intern(theory.ab, (c,)) for c in theory.components}
        done = 0
        while done < len(self.keys):  # so that every complement has an id (to a fixpoint:
            other = self._complement_key(self.keys[done])  # not_not_a -> not_a -> a)
            if other is not None:
                self._intern(*other)
            done += 1
        self.false_id = self.ids.get((FALSE, ()), -1)
        self.complement = [-1] * len(self.keys)
        for i, key in enumerate(self.keys):
            other = self._complement_key(key)
            if other is not None:
                self.complement[i] = self.ids[other]
        self.assumption: dict[int, tuple[str, bool]] = {}  # atom -> (component, is AB)
        for comp in theory.components:
            self.assumption[self.nab_id[comp]] = (comp, False)
            self.assumption[self.ab_id[comp]] = (comp, True)
        self.head = heads
        self.body = bodies
        self.occurs: list[list[int]] = [[] for _ in self.keys]
        for k, body in enumerate(bodies):
            for a in body:
                self.occurs[a].append(k)
        self.facts = [k for k, body in enumerate(bodies) if not body]
        self.by_head: list[list[int]] = [[] for _ in self.keys]
        for k, h in enumerate(heads):
            self.by_head[h].append(k)
        self.size = [len(b) for b in bodies]
        self.monotone = self._is_monotone()
        self.all_nab = [self.nab_id[c] for c in theory.components]
        # (predicate, args, positive) of an observation literal -> atom id
        self.literal_ids: dict[tuple[str, tuple[str, ...], bool], int] = {}
        prefix = theory.neg_prefix
        for i, (pred, args) in enumerate(self.keys):
            if pred in (theory.ab, theory.nab) or (pred, args) == (FALSE, ()):
                continue
            if pred.startswith(prefix):
                self.literal_ids[pred.removeprefix(prefix), args, False] = i
            else:
                self.literal_ids[pred, args, True] = i

    def _intern(self, predicate: str, args: tuple[str, ...]) -> int:
        key = (predicate, args)
        found = self.ids.get(key)
        if found is None:
            found = self.ids[key] = len(self.keys)
            self.keys.append(key)
        return found

    def _complement_key(self, key: Key) -> Key | None:
        pred, args = key
        theory = self.theory
        if key == (FALSE, ()):
            return None
        if pred == theory.ab:
            return theory.nab, args
        if pred == theory.nab:
            return theory.ab, args
        if pred.startswith(theory.neg_prefix):
            return pred.removeprefix(theory.neg_prefix), args
        return theory.neg_prefix + pred, args

    def atom_id(self, atom: Atom) -> int | None:
        return self.ids.get((atom.predicate, atom.args))

    def _is_monotone(self) -> bool:
        """True when assuming AB(c) can never matter: AB only ever blocks NAB.

        Then Reiter's theory applies as is (Theorem 3.1): diagnoses are exactly the minimal
        hitting sets of the minimal conflicts.  Fault-mode rules break this.
        """
        ab = self.theory.ab
        nab = self.theory.nab
        for clause in self.theory.clauses:
            if clause.head.predicate in (ab, nab):
                return False
            if any(a.predicate == ab for a in clause.body):
                return False
        return True

    def literal_atom(self, literal: Literal) -> int:
        found = self.literal_ids.get((literal.atom.predicate, literal.atom.args, literal.positive))
        if found is None:
            atom = literal.atom if literal.positive else self.theory.negate(literal.atom)
            hint = did_you_mean(str(atom), (str(Atom(*k)) for k in self.keys))
            raise RacError(
                [Diagnostic("RAC040", f"unknown atom '{atom}' in an observation", hint=hint)]
            )
        return found

    def base(self, observations: Sequence[Literal]) -> tuple[Base, tuple[int, ...]]:
        """The closure of facts ∪ Θ, and the clash it already holds (() when none)."""
        true = bytearray(len(self.keys))
        missing = list(self.size)
        seeds = [self.head[k] for k in self.facts]
        ids = self.literal_ids
        for lit in observations:
            atom = lit.atom
            found = ids.get((atom.predicate, atom.args, lit.positive))
            seeds.append(self.literal_atom(lit) if found is None else found)  # raises RAC040
        occurs, head = self.occurs, self.head
        stack: list[int] = []
        for a in seeds:
            if not true[a]:
                true[a] = 1
                stack.append(a)
        held = list(stack)  # every atom made true, for the clash scan below
        while stack:
            a = stack.pop()
            for k in occurs[a]:
                missing[k] -= 1
                if missing[k] == 0 and not true[head[k]]:
                    true[head[k]] = 1
                    stack.append(head[k])
                    held.append(head[k])
        return Base(true, missing), self._clash(true, held)

    def _clash(self, true: bytearray, held: list[int]) -> tuple[int, ...]:
        if self.false_id >= 0 and true[self.false_id]:
            return (self.false_id,)
        complement = self.complement
        for a in held:
            c = complement[a]
            if c >= 0 and true[c]:
                return (min(a, c), max(a, c))
        return ()

    def run(self, base: Base, seeds: Iterable[int], stop: bool = True) -> Run:
        """Propagate assumption atoms on ``base``; stop at the first contradiction.

        With ``stop=False`` the closure is computed in full and ``clash`` is the first one met.
        Works on copies of the base arrays: copying is a C-speed memcpy, far cheaper than
        per-clause dictionary look-ups when the run touches most of the model.
        """
        true = bytearray(base.true)
        missing = base.missing.copy()
        occurs, head, complement, false_id = self.occurs, self.head, self.complement, self.false_id
        why: dict[int, int] = {}
        stack: list[int] = []
        clash: tuple[int, ...] = ()
        for a in seeds:
            if true[a]:
                continue
            true[a] = 1
            why[a] = ASSUMED
            c = complement[a]
            if c >= 0 and true[c] and not clash:
                clash = (a, c)
                if stop:
                    return Run(clash, why)
            stack.append(a)
        while stack:
            a = stack.pop()
            for k in occurs[a]:
                missing[k] -= 1
                if missing[k] == 0:
                    h = head[k]
                    if true[h]:
                        continue
                    true[h] = 1
                    why[h] = k
                    c = complement[h]
                    if h == false_id or (c >= 0 and true[c]):
                        if not clash:
                            clash = (h,) if h == false_id else (h, c)
                        if stop:
                            return Run(clash, why)
                    stack.append(h)
        return Run(clash, why)

    def full(self, base: Base) -> Full:
        """Close ``base`` under NAB(c) for every component, recording every contradiction."""
        true = bytearray(base.true)
        missing = base.missing.copy()
        occurs, head = self.occurs, self.head
        why: dict[int, int] = {}
        stack: list[int] = []
        for a in self.all_nab:
            if not true[a]:
                true[a] = 1
                why[a] = ASSUMED
                stack.append(a)
        while stack:
            a = stack.pop()
            for k in occurs[a]:
                missing[k] -= 1
                if missing[k] == 0 and not true[head[k]]:
                    true[head[k]] = 1
                    why[head[k]] = k
                    stack.append(head[k])
        complement, false_id = self.complement, self.false_id
        clashes: set[tuple[int, ...]] = set()
        for a in why:
            c = complement[a]
            if a == false_id:
                clashes.add((a,))
            elif c >= 0 and true[c]:
                clashes.add((min(a, c), max(a, c)))
        return Full(true, missing, why, tuple(sorted(clashes)))

    def check(self, base: Base, full: Full, bad: frozenset[str], strong: bool) -> Run:
        """Is AB(bad) ∪ NAB(COMPS∖bad) consistent with Θ?  Incremental on ``full``.

        Delete and rederive (DRed): drop everything that NAB(bad) supported in ``full``,
        restore what still has a derivation, then add AB(bad).  The cost is the cone of
        ``bad`` in the model, not the model: a candidate diagnosis is checked in the time
        its components' consequences take.
        """
        true_f, missing_f, base_true = full.true, full.missing, base.true
        occurs, head, complement, false_id = self.occurs, self.head, self.complement, self.false_id
        why_f = full.why
        # 1. over-delete the consequences of the retracted assumptions
        lost: set[int] = set()
        stack = [self.nab_id[c] for c in sorted(bad) if not base_true[self.nab_id[c]]]
        lost.update(stack)
        lost_in_body: dict[int, int] = {}
        while stack:
            a = stack.pop()
            for k in occurs[a]:
                lost_in_body[k] = lost_in_body.get(k, 0) + 1
                if missing_f[k] == 0:
                    h = head[k]
                    if h not in lost and not base_true[h] and why_f.get(h) != ASSUMED:
                        lost.add(h)
                        stack.append(h)
        # 2. rederive and 3. add AB(bad): one propagation over the current state
        new: set[int] = set()
        why: dict[int, int] = {}
        missing: dict[int, int] = {}

        def holds(x: int) -> bool:
            return (bool(true_f[x]) and x not in lost) or x in new

        clash: tuple[int, ...] = ()

        def make_true(a: int, k: int) -> bool:
            """Mark ``a`` true; True when that contradicts the current state."""
            nonlocal clash
            if a in lost:
                lost.discard(a)
            else:
                new.add(a)
            why[a] = k
            stack.append(a)
            c = complement[a]
            if a == false_id or (c >= 0 and holds(c)):
                clash = (a,) if a == false_id else (a, c)
                return True
            return False

        for h in sorted(lost):
            for k in self.by_head[h]:
                restorable = missing_f[k] == 0 and k not in lost_in_body and h in lost
                if restorable and make_true(h, k):
                    return Run(clash, ChainMap(why, why_f))
        if strong:
            for c in sorted(bad):
                a = self.ab_id[c]
                if not holds(a) and make_true(a, ASSUMED):
                    return Run(clash, ChainMap(why, why_f))
        while stack:
            a = stack.pop()
            for k in occurs[a]:
                m = missing.get(k)
                if m is None:
                    m = missing_f[k] + lost_in_body.get(k, 0)
                m -= 1
                missing[k] = m
                if m == 0 and not holds(head[k]) and make_true(head[k], k):
                    return Run(clash, ChainMap(why, why_f))
        for pair in full.clashes:
            if all(holds(x) for x in pair):
                return Run(pair, ChainMap(why, why_f))
        return Run((), ChainMap(why, why_f))

    def support(self, result: Run) -> frozenset[int]:
        """The assumption atoms the contradiction of ``result`` was derived from."""
        why, body = result.why, self.body
        found: set[int] = set()
        seen: set[int] = set()
        stack = list(result.clash)
        while stack:
            a = stack.pop()
            if a in seen:
                continue
            seen.add(a)
            k = why.get(a)
            if k is None:  # true in the base: follows from Θ alone
                continue
            if k == ASSUMED:
                found.add(a)
            else:
                stack.extend(body[k])
        return frozenset(found)

    def minimal_conflict(self, base: Base, conflict: frozenset[int]) -> frozenset[int]:
        """Shrink a set of assumption atoms that contradicts Θ to a subset-minimal one.

        Deletion-based: drop one atom at a time and keep the (traced) smaller conflict when
        the rest still contradicts.  Inconsistency is monotone in the assumptions (Horn), so
        an atom found necessary stays necessary in every subset.
        """
        kept = sorted(conflict)
        i = 0
        while i < len(kept):
            trial = kept[:i] + kept[i + 1 :]
            result = self.run(base, trial)
            if not result.clash:
                i += 1
                continue
            support = self.support(result)
            kept = kept[:i] + [a for a in kept[i + 1 :] if a in support]
        return frozenset(kept)

    def assignment(self, bad: frozenset[str], strong: bool) -> list[int]:
        """AB(c) for c in bad (when ``strong``) and NAB(c) for every other component."""
        seeds = [a for a in self.all_nab if self.assumption[a][0] not in bad]
        if strong:
            seeds.extend(self.ab_id[c] for c in sorted(bad))
        return seeds
