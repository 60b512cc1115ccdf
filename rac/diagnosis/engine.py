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
from itertools import compress, count
from operator import itemgetter, not_
from typing import cast

from rac.diagnosis.theory import Key, Literal, Theory
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.logic import FALSE, Atom
from rac.perf import paused_gc

ASSUMED = -1  # justification of an atom that was assumed, not derived
# A conflict this small is shrunk by deletion alone: a test per atom costs less than a pass of
# Index.necessary over the whole closure.
_DELETION_ONLY = 4
_first, _second = itemgetter(0), itemgetter(1)


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


def _intern(ids: dict[Key, int], key: Key) -> int:
    found = ids.get(key)
    if found is None:
        found = ids[key] = len(ids)
    return found


def assumptions_behind(
    atoms: Iterable[int],
    why: Mapping[int, int],
    body: Sequence[Sequence[int]],
    limit: int | None = None,
) -> set[int]:
    """The assumption atoms ``atoms`` were derived from, following each atom's clause in
    ``why`` back to atoms assumed (:data:`ASSUMED`) or true in the base (absent from ``why``).

    With ``limit`` the trace stops once that many are found.  A ``why`` that is a
    :class:`~collections.ChainMap` of two dictionaries (:meth:`Index.check`'s) is read map by
    map: its own ``get`` runs in Python, once per atom of a trace as long as the model.
    """
    # only a check of derivations (by_head) makes a trace give None
    return cast(set[int], _trace(atoms, why, body, limit, None, None))


def assumptions_of_one_derivation(
    atoms: Iterable[int],
    closure: Full,
    body: Sequence[Sequence[int]],
    by_head: Sequence[Sequence[int]],
) -> set[int] | None:
    """:func:`assumptions_behind` of ``atoms`` in ``closure`` when every atom they were derived
    from has one derivation (no other clause of it fired; no clause at all when it was
    assumed), which makes those assumptions needed by every derivation; None otherwise."""
    return _trace(atoms, closure.why, body, None, by_head, closure.missing)


def _trace(
    atoms: Iterable[int],
    why: Mapping[int, int],
    body: Sequence[Sequence[int]],
    limit: int | None,
    by_head: Sequence[Sequence[int]] | None,
    missing: Sequence[int] | None,
) -> set[int] | None:
    """The one trace behind :func:`assumptions_behind` and
    :func:`assumptions_of_one_derivation`: depth first, a clause's body pushed last atom
    first, so that a clause's own assumptions are met before the atoms it was derived
    from (a limit is reached without walking a chain to its start)."""
    nothing: dict[int, int] = {}
    maps = why.maps if isinstance(why, ChainMap) and len(why.maps) == 2 else [why, nothing]
    find_changed, find_rest = maps[0].get, maps[1].get
    found: set[int] = set()
    seen: set[int] = set()
    stack = list(atoms)
    stop = -1 if limit is None else limit  # found grows one by one: never -1
    while stack and len(found) != stop:
        a = stack.pop()
        if a in seen:
            continue
        seen.add(a)
        k = find_changed(a)
        if k is None:
            k = find_rest(a)
            if k is None:  # true in the base: follows from Θ alone
                continue
        if by_head is not None and missing is not None:
            deriving = by_head[a]  # no clause for an assumption, one for a chain's link
            several = deriving and (k == ASSUMED or len(deriving) > 1)
            if several and any(missing[j] == 0 for j in deriving if j != k):
                return None  # a second derivation
        if k == ASSUMED:
            found.add(a)
        else:
            stack.extend(reversed(body[k]))
    return found


def _number(theory: Theory, ids: dict[Key, int]) -> tuple[list[int], list[list[int]]]:
    """Number the atoms of the clauses (heads, then bodies) and props in ``ids``: the
    order a clause table numbers them in."""
    by_object: dict[int, int] = {}  # a model read from a file shares one object per atom

    def atom_id(atom: Atom) -> int:
        found = by_object.get(id(atom))
        if found is None:
            found = by_object[id(atom)] = _intern(ids, (atom.predicate, atom.args))
        return found

    clauses = theory.clauses
    heads = [atom_id(c.head) for c in clauses]
    bodies = [[atom_id(a) for a in c.body] for c in clauses]
    for k, body in enumerate(bodies):
        if len(body) > 1 and len(set(body)) < len(body):
            bodies[k] = list(dict.fromkeys(body))  # a repeated body atom counts once
    for atom in theory.props:
        atom_id(atom)
    return heads, bodies


class KnownAtoms:
    """``rac.diagnosis.theory.known_atoms`` of an index's theory as a look-up, not a set.

    An atom is known when the theory mentions it, or its negation ``not_atom``, and it is
    neither an assumption nor ``false``.
    """

    def __init__(self, index: Index) -> None:
        self.index = index

    def __contains__(self, atom: object) -> bool:
        if not isinstance(atom, Atom):
            return False
        theory, ids, mentioned = self.index.theory, self.index.ids, self.index.mentioned
        pred, args = atom.predicate, atom.args
        if pred in (theory.ab, theory.nab) or (pred == FALSE and not args):
            return False
        if not pred.startswith(theory.neg_prefix) and ids.get((pred, args), mentioned) < mentioned:
            return True
        return ids.get((theory.neg_prefix + pred, args), mentioned) < mentioned


class Index:
    """The clause set of a theory as integer arrays, built once and reused for every check.

    Atoms are numbered in two ranges.  Below ``named`` are the atoms of the look-up ``ids``:
    those the theory mentions and the NAB atoms of components it does not.  From ``named``
    on are the complements nothing mentions (``not_p`` of a mentioned ``p``, AB of a NAB):
    each exists only as a number and its complement's, so that the index never builds a
    key or a dictionary entry for atoms the model does not mention, which are most of them.
    """

    def __init__(self, theory: Theory) -> None:
        with paused_gc():  # hundreds of thousands of small lists and tuples, none cyclic
            self._build(theory)

    def _build(self, theory: Theory) -> None:
        self.theory = theory
        # Atoms are keyed by (predicate, args): tuple hashing runs in C, Atom's in Python,
        # which matters at 100,000 atoms.
        heads: Sequence[int]
        bodies: Sequence[Sequence[int]]
        table = theory.table
        comps = theory.components
        if table is not None and table.clauses is theory.clauses and table.props is theory.props:
            ids: Mapping[Key, int] = table.ids  # the reader's own look-up, used as it is
            heads, bodies = table.heads, table.bodies
            nab_ids = list(map(table.nab.get, comps))
        else:
            own: dict[Key, int] = {}
            heads, bodies = _number(theory, own)
            ids = own
            nab_ids = list(map(ids.get, [(theory.nab, (c,)) for c in comps]))
        self.mentioned = len(ids)  # atoms below this id occur in the theory itself
        if None in nab_ids:  # components no rule mentions: their NAB gets a number
            grown = dict(ids)  # the reader's look-up stays as it was
            nab_ids = [_intern(grown, (theory.nab, (c,))) for c in comps]
            ids = grown
        self.ids: Mapping[Key, int] = ids
        self._keys: list[Key] | None = None
        self.complement = self._complements()
        self.named = len(self.ids)  # the fallback of _complements may have named more
        self.count = len(self.complement)
        self.false_id = self.ids.get((FALSE, ()), -1)
        self.all_nab = cast(list[int], nab_ids)  # no None left
        ab_ids = list(map(self.complement.__getitem__, self.all_nab))  # AB(c) = ¬NAB(c)
        self.nab_atoms = frozenset(self.all_nab)
        self.ab_atoms = frozenset(ab_ids)
        self.nab_id = dict(zip(comps, self.all_nab, strict=True))
        self.ab_id = dict(zip(comps, ab_ids, strict=True))
        # assumption atom (NAB or AB) -> its component
        self.component = dict(zip(self.all_nab, comps, strict=True))
        self.component.update(zip(ab_ids, comps, strict=True))
        self.head = heads
        self.body = bodies
        self.occurs = self._occurrences(bodies)
        self.size = list(map(len, bodies))
        self.facts = list(compress(count(), map(not_, self.size)))
        self._by_head: list[list[int]] | None = None
        self.monotone = self._is_monotone(ab_ids)
        self._normal: Full | None = None
        self.known = KnownAtoms(self)

    @property
    def keys(self) -> list[Key]:
        """Every atom's (predicate, args), by number: the unnamed complements spelt out
        (built on first use: error messages and tests read it, checks never do)."""
        if self._keys is None:
            keys = list(self.ids)
            other = self._complement_predicate
            keys.extend([(other(keys[a][0]), keys[a][1]) for a in self.complement[self.named :]])
            self._keys = keys
        return self._keys

    def _complements(self) -> list[int]:
        """Each atom's complement (``p`` <-> ``not_p``, ``AB`` <-> ``NAB``); -1 for ``false``.

        A complement the look-up lacks gets the next number from ``named`` on, in atom
        order.  Whether it is lacking is decided per predicate: an atom is looked up only
        when its predicate's complement occurs at all, which in a compiled model is rare.
        """
        ids = self.ids
        other_of = {p: self._complement_predicate(p) for p in dict.fromkeys(map(_first, ids))}
        if any(self._complement_predicate(q) != p for p, q in other_of.items()):
            return self._complements_named()  # not_not_p: complements chain
        paired = {p for p, q in other_of.items() if q in other_of}
        false_id = ids.get((FALSE, ()), -1)
        named = len(ids)
        if not paired:  # the usual case: every complement lacks, but false's (it has none)
            lacking = [*range(false_id), *range(false_id + 1, named)]
            complement = list(range(named, named + len(lacking)))
            if false_id >= 0:
                complement.insert(false_id, -1)
        else:
            lacks = -2
            complement = [lacks] * named
            keys = list(ids)
            for a in compress(count(), map(paired.__contains__, map(_first, keys))):
                pred, args = keys[a]
                complement[a] = ids.get((other_of[pred], args), lacks)
            if false_id >= 0:
                complement[false_id] = -1  # false has no complement
            # C loops (no numpy: a command on a small model would pay more for its import)
            lacking = list(compress(count(), map(lacks.__eq__, complement)))
            any(map(complement.__setitem__, lacking, count(named)))
        complement.extend(lacking)  # an unnamed complement's complement is its atom
        return complement

    def _complements_named(self) -> list[int]:
        """:meth:`_complements` when complementing twice does not give the atom back
        (``not_not_a`` -> ``not_a`` -> ``a``): every complement is named in ``ids``, in
        rounds to a fixpoint, as a model with such predicates is small and hand-written."""
        ids = dict(self.ids)
        keys = list(ids)
        none = ""  # the "predicate" of a missing complement: no atom has it
        false_id = ids.get((FALSE, ()), -1)
        complement: list[int] = []
        done = 0
        while done < len(keys):
            for a in range(done, len(keys)):
                pred, args = keys[a]
                wanted = (none, ()) if a == false_id else (self._complement_predicate(pred), args)
                found = ids.get(wanted, -1)
                if found < 0 and wanted[0]:
                    found = _intern(ids, wanted)
                    keys.append(wanted)
                complement.append(found)
            done = len(complement)
        self.ids = ids
        return complement

    def _occurrences(self, bodies: Sequence[Sequence[int]]) -> list[Sequence[int]]:
        """The clauses each atom occurs in the body of.  Most atoms (heads, complements)
        occur in none and share one empty tuple: a list per atom is a hundred thousand
        allocations on a large model, and allocation is what scales worst there."""
        none: Sequence[int] = ()
        occurs: list[Sequence[int]] = [none] * self.count
        for k, body in enumerate(bodies):
            for a in body:
                found = occurs[a]
                if found is none:
                    occurs[a] = [k]
                else:
                    found.append(k)  # type: ignore[attr-defined]  # a list once non-empty
        return occurs

    @property
    def by_head(self) -> list[list[int]]:
        """The clauses deriving each atom (built on first use: only DRed needs it)."""
        if self._by_head is None:
            by_head: list[list[int]] = [[] for _ in range(self.count)]
            for k, h in enumerate(self.head):
                by_head[h].append(k)
            self._by_head = by_head
        return self._by_head

    def _complement_predicate(self, pred: str) -> str:
        theory = self.theory
        if pred == theory.ab:
            return theory.nab
        if pred == theory.nab:
            return theory.ab
        if pred.startswith(theory.neg_prefix):
            return pred.removeprefix(theory.neg_prefix)
        return theory.neg_prefix + pred

    def number(self, key: Key) -> int | None:
        """The atom ``key`` names, unnamed complements included; None when there is none."""
        found = self.ids.get(key)
        if found is None and self.count > self.named:
            pred, args = key
            other = self._complement_predicate(pred)
            if self._complement_predicate(other) == pred:
                atom = self.ids.get((other, args))
                if atom is not None and self.complement[atom] >= self.named:
                    return self.complement[atom]
        return found

    def is_ab(self, assumption: int) -> bool:
        """Is the assumption atom AB(c), not NAB(c)?"""
        return self.ab_id[self.component[assumption]] == assumption

    def atom_id(self, atom: Atom) -> int | None:
        return self.number((atom.predicate, atom.args))

    def _is_monotone(self, ab_ids: list[int]) -> bool:
        """True when assuming AB(c) can never matter: AB only ever blocks NAB.

        Then Reiter's theory applies as is (Theorem 3.1): diagnoses are exactly the minimal
        hitting sets of the minimal conflicts.  Fault-mode rules break this.
        """
        if not self.component.keys().isdisjoint(self.head):
            return False
        return not any(map(self.occurs.__getitem__, ab_ids))

    def literal_id(self, predicate: str, args: tuple[str, ...], positive: bool) -> int | None:
        """The atom of the literal ``predicate(args)`` (``not_predicate(args)`` when negative),
        None when the theory does not know it or it is AB, NAB or ``false``."""
        theory = self.theory
        key = (predicate, args) if positive else (theory.neg_prefix + predicate, args)
        if key[0] in (theory.ab, theory.nab) or key == (FALSE, ()):
            return None
        if positive and predicate.startswith(theory.neg_prefix):
            return None  # a literal never carries the prefix
        return self.number(key)

    def literal_atom(self, literal: Literal) -> int:
        found = self.literal_id(literal.atom.predicate, literal.atom.args, literal.positive)
        if found is None:
            atom = literal.atom if literal.positive else self.theory.negate(literal.atom)
            hint = did_you_mean(str(atom), (str(Atom(*k)) for k in self.keys))
            raise RacError(
                [Diagnostic("RAC040", f"unknown atom '{atom}' in an observation", hint=hint)]
            )
        return found

    def base(self, observations: Sequence[Literal]) -> tuple[Base, tuple[int, ...]]:
        """The closure of facts ∪ Θ, and the clash it already holds (() when none)."""
        return self.base_ids(self._observed(observations))

    def base_ids(self, observed: Sequence[int]) -> tuple[Base, tuple[int, ...]]:
        """:meth:`base` of Θ given as atom numbers (:meth:`observed_ids`)."""
        true = bytearray(self.count)
        missing = list(self.size)
        seeds = [self.head[k] for k in self.facts]
        seeds.extend(observed)
        stack: list[int] = []
        clash = self._seed(true, seeds, {}, stack, stop=False)
        found = self._propagate(true, missing, stack, {}, stop=False)
        return Base(true, missing), clash or found

    def _observed(self, observations: Sequence[Literal]) -> list[int]:
        # literal_id's common case inlined: tens of thousands of observations per call
        ids, complement, prefix = self.ids, self.complement, self.theory.neg_prefix
        excluded = {self.theory.ab, self.theory.nab, FALSE}
        found = []
        for lit in observations:
            pred = lit.atom.predicate
            i = None
            if pred not in excluded and not pred.startswith(prefix):
                i = ids.get((pred, lit.atom.args))
                if i is not None and not lit.positive:
                    i = complement[i]
            if i is None:
                i = self.literal_atom(lit)  # the other cases, or RAC040
            found.append(i)
        return found

    def plain_ids(self, lines: Sequence[tuple[str, str, str]]) -> list[int] | None:
        """Plain literal lines (:func:`rac.diagnosis.theory.plain_lines`) as atom numbers,
        when every one names an observable atom the theory knows; None otherwise (the
        literal parser then reads them, and says what is wrong and where)."""
        ids, complement, mentioned = self.ids, self.complement, self.mentioned
        prefix, excluded = self.theory.neg_prefix, {self.theory.ab, self.theory.nab, FALSE}
        found: list[int] = []
        for negation, pred, args in lines:
            if pred in excluded or pred.startswith(prefix):
                return None
            key = (pred, tuple(args.split(",")) if args else ())
            i = ids.get(key, -1)
            if not 0 <= i < mentioned:  # then the theory must mention its negation
                negative = ids.get((prefix + pred, key[1]), -1)
                if not 0 <= negative < mentioned:
                    return None  # unknown: the theory mentions neither
                i = complement[negative]
            found.append(complement[i] if negation else i)
        return found

    def collect_ids(self, observed: Sequence[int]) -> list[int]:
        """``rac.diagnosis.theory.collect`` on atom numbers: a later observation replaces an
        earlier one of the same atom or of its negation; kept in the order of the last."""
        complement = self.complement
        seen: set[int] = set()
        kept: list[int] = []
        for i in reversed(observed):
            if i not in seen:
                seen.add(i)
                seen.add(complement[i])
                kept.append(i)
        kept.reverse()
        return kept

    def _seed(
        self,
        true: bytearray,
        seeds: Iterable[int],
        why: dict[int, int],
        stack: list[int],
        stop: bool,
    ) -> tuple[int, ...]:
        """Make ``seeds`` true (pushing the new ones on ``stack``); the first clash met."""
        complement, false_id = self.complement, self.false_id
        clash: tuple[int, ...] = ()
        for a in seeds:
            if true[a]:
                continue
            true[a] = 1
            why[a] = ASSUMED
            c = complement[a]
            if not clash and (a == false_id or (c >= 0 and true[c])):
                clash = (a,) if a == false_id else (a, c)
                if stop:
                    return clash
            stack.append(a)
        return clash

    def _propagate(
        self, true: bytearray, missing: list[int], stack: list[int], why: dict[int, int], stop: bool
    ) -> tuple[int, ...]:
        """Counter-based unit propagation (LTUR) from the atoms on ``stack``: the one loop.

        Every derived atom is recorded in ``why`` with its clause.  Returns the first
        contradiction met (() when none), and stops there when ``stop``.
        """
        occurs, head, complement, false_id = self.occurs, self.head, self.complement, self.false_id
        clash: tuple[int, ...] = ()
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
                            return clash
                    stack.append(h)
        return clash

    def run(self, base: Base, seeds: Iterable[int], stop: bool = True) -> Run:
        """Propagate assumption atoms on ``base``; stop at the first contradiction.

        With ``stop=False`` the closure is computed in full and ``clash`` is the first one met.
        Works on copies of the base arrays: copying is a C-speed memcpy, far cheaper than
        per-clause dictionary look-ups when the run touches most of the model.
        """
        true = bytearray(base.true)
        why: dict[int, int] = {}
        stack: list[int] = []
        clash = self._seed(true, seeds, why, stack, stop)
        if clash and stop:
            return Run(clash, why)
        found = self._propagate(true, base.missing.copy(), stack, why, stop)
        return Run(clash or found, why)

    def full(self, base: Base) -> Full:
        """Close ``base`` under NAB(c) for every component, recording every contradiction."""
        return self.closure(base, self.all_nab)

    def closure(self, base: Base, assumed: Iterable[int]) -> Full:
        """Close ``base`` under the ``assumed`` atoms, recording every contradiction."""
        true = bytearray(base.true)
        missing = base.missing.copy()
        why: dict[int, int] = {}
        stack: list[int] = []
        self._seed(true, assumed, why, stack, stop=False)
        self._propagate(true, missing, stack, why, stop=False)
        complement, false_id = self.complement, self.false_id
        clashes: set[tuple[int, ...]] = set()
        for a in why:
            c = complement[a]
            if a == false_id:
                clashes.add((a,))
            elif c >= 0 and true[c]:
                clashes.add((min(a, c), max(a, c)))
        return Full(true, missing, why, tuple(sorted(clashes)))

    def normal(self) -> Full:
        """The closure of the facts and NAB(COMPS), without observations; computed once.

        Every consistency check of the all-normal assumption starts from it, so that a check
        costs the observations and what they add, not the whole model.
        """
        if self._normal is None:
            base, clash = self.base(())
            full = self.full(base)
            # a clash of the facts alone stays in every closure: keep it with the others
            clashes = full.clashes + ((clash,) if clash else ())
            self._normal = Full(full.true, full.missing, full.why, clashes)
        return self._normal

    def consistent(self, observations: Sequence[Literal]) -> bool:
        """Is clauses ∪ Θ ∪ NAB(COMPS) consistent?  Incremental on :meth:`normal`."""
        return self.consistent_ids(self._observed(observations))

    def observed_ids(self, observations: Sequence[Literal]) -> list[int]:
        """Θ as atom ids (RacError RAC040 for an unknown atom): convert once, check often."""
        return self._observed(observations)

    def consistent_ids(self, atoms: Sequence[int]) -> bool:
        """:meth:`consistent` of Θ given as atom ids (:meth:`observed_ids`).

        Only the observations the all-normal closure does not already hold are propagated;
        finding them is one vectorised look-up, so a check of an expected Θ costs a few
        array operations however large Θ is.
        """
        import numpy as np  # on first use: most commands never check this way

        normal = self.normal()
        if normal.clashes:
            return False
        seeds = np.asarray(atoms, dtype=np.int64)
        held = np.frombuffer(normal.true, dtype=np.uint8)
        new = seeds[held[seeds] == 0].tolist() if seeds.size else []
        if not new:  # everything observed was already predicted
            return True
        true = bytearray(normal.true)
        stack: list[int] = []
        if self._seed(true, new, {}, stack, stop=True):
            return False
        return not self._propagate(true, normal.missing.copy(), stack, {}, stop=True)

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
        return frozenset(assumptions_behind(result.clash, result.why, self.body))

    def necessary(
        self,
        base: Base,
        assumed: Sequence[int],
        candidates: Sequence[int],
        closure: Full | None = None,
    ) -> frozenset[int]:
        """The ``candidates`` without which facts ∪ Θ ∪ ``assumed`` is consistent: the
        assumptions in every derivation of every contradiction, in one pass.

        ``assumed`` must contradict Θ; ``closure`` is :meth:`closure` of ``base`` under
        ``assumed`` when the caller has it.  When the closure holds one contradiction and
        every atom it was derived from has one derivation (a chain, a fan-in), the answer is
        the assumptions that derivation traces back to.  Otherwise each atom of the closure
        gets the set of candidates every one of its derivations uses, as a bit mask: an
        assumption its own bit, an atom of the base none, a derived atom the intersection
        over the clauses deriving it of the union over their bodies (the greatest solution,
        found by a work list, so cycles and clauses that fire after their head was derived
        are handled).  A contradiction needs the union of its two atoms' sets, and the
        answer is the intersection over all of them.  Where deletion tests each candidate by
        a propagation of its own (quadratic on a chain of n components), this costs one
        closure and one mask operation per clause.
        """
        if closure is None:
            closure = self.closure(base, assumed)
        if len(closure.clashes) == 1:
            traced = assumptions_of_one_derivation(
                closure.clashes[0], closure, self.body, self.by_head
            )
            if traced is not None:
                return frozenset(a for a in candidates if a in traced)
        return self._necessary_by_masks(closure, candidates)

    def _necessary_by_masks(self, closure: Full, candidates: Sequence[int]) -> frozenset[int]:
        """:meth:`necessary` by the bit masks of its docstring."""
        true, missing, why = closure.true, closure.missing, closure.why
        bit = {a: 1 << i for i, a in enumerate(candidates)}
        every = (1 << len(candidates)) - 1
        body, by_head = self.body, self.by_head
        # atoms beyond the base (an atom of the base needs nothing): an assumed one needs
        # itself, unless a clause derives it too (with fault-mode rules NAB can be a head)
        own = {a: bit.get(a, 0) if k == ASSUMED else every for a, k in why.items()}
        mask = dict(own)
        firing: dict[int, list[int]] = {}
        users: dict[int, list[int]] = {}
        for a in why:
            fired = [j for j in by_head[a] if missing[j] == 0]
            if not fired:
                continue
            firing[a] = fired
            for j in fired:
                for b in body[j]:
                    if b in why:
                        users.setdefault(b, []).append(a)
        pending = [a for a in reversed(why) if a in firing]  # popped in derivation order
        queued = set(pending)
        while pending:
            a = pending.pop()
            queued.discard(a)
            found = own[a]
            for j in firing[a]:
                need = 0
                for b in body[j]:
                    need |= mask.get(b, 0)
                found &= need
            if found != mask[a]:
                mask[a] = found
                for user in users.get(a, ()):
                    if user not in queued:
                        queued.add(user)
                        pending.append(user)
        complement, false_id = self.complement, self.false_id
        common = every
        for a in why:
            c = complement[a]
            if a == false_id:
                common &= mask[a]
            elif c >= 0 and true[c]:
                common &= mask[a] | mask.get(c, 0)
        return frozenset(a for a in candidates if common & bit[a])

    def minimal_conflict(
        self,
        base: Base,
        conflict: frozenset[int],
        needed_under: dict[frozenset[int], frozenset[int]] | None = None,
        closure: Full | None = None,
    ) -> frozenset[int]:
        """Shrink a set of assumption atoms that contradicts Θ to a subset-minimal one.

        Deletion-based: drop one atom at a time and keep the (traced) smaller conflict when
        the rest still contradicts.  Inconsistency is monotone in the assumptions (Horn), so
        an atom found necessary stays necessary in every subset: the atoms :meth:`necessary`
        finds are never tested, and when they contradict Θ by themselves they are the only
        minimal conflict inside ``conflict`` (what deletion would have found, one test each).
        ``needed_under`` gets ``conflict`` -> those atoms, when they were computed: the
        members of any set of candidates within ``conflict`` that every contradiction under
        ``conflict`` needs, without another pass.  ``closure`` is :meth:`closure` of ``base``
        under ``conflict`` when the caller has it.
        """
        kept = sorted(conflict)
        needed: frozenset[int] = frozenset()
        if len(kept) > _DELETION_ONLY:
            needed = self.necessary(base, kept, kept, closure)
            if needed_under is not None:
                needed_under[conflict] = needed
            if len(needed) == len(kept):  # all of the conflict, which contradicts Θ
                return needed
            if needed and self.run(base, sorted(needed)).clash:
                return needed
        i = 0
        while i < len(kept):
            if kept[i] in needed:  # the rest is consistent without it: kept as deletion would
                i += 1
                continue
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
        seeds = [a for a in self.all_nab if self.component[a] not in bad]
        if strong:
            seeds.extend(self.ab_id[c] for c in sorted(bad))
        return seeds
