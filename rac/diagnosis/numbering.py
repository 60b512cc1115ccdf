"""Atoms as numbers: the names of a theory's atoms, their complements and components, and
observation literals converted to numbers.

Every atom, ``not_p`` included, is its own proposition with its own number; ``p`` and
``not_p``, ``AB(c)`` and ``NAB(c)`` are each other's complement.  The clauses are numbered
in the same pass (heads, then bodies, then the props), so that propagation
(:mod:`rac.diagnosis.propagation`) works on integer arrays only.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from itertools import compress, count, repeat
from operator import attrgetter, is_, itemgetter, not_
from typing import cast

from rac.diagnosis.theory import Key, Literal, Theory
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.logic import FALSE, Atom

_first = itemgetter(0)
_key_of = attrgetter("atom.predicate", "atom.args")  # an observation's atom as a key
_positive_of = attrgetter("positive")


def _intern(ids: dict[Key, int], key: Key) -> int:
    found = ids.get(key)
    if found is None:
        found = ids[key] = len(ids)
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
    """``rac.diagnosis.theory.known_atoms`` of a numbering's theory as a look-up, not a set.

    An atom is known when the theory mentions it, or its negation ``not_atom``, and it is
    neither an assumption nor ``false``.
    """

    def __init__(self, numbering: AtomNumbering) -> None:
        self.numbering = numbering

    def __contains__(self, atom: object) -> bool:
        if not isinstance(atom, Atom):
            return False
        theory, ids, mentioned = self.numbering.theory, self.numbering.ids, self.numbering.mentioned
        pred, args = atom.predicate, atom.args
        if pred in (theory.ab, theory.nab) or (pred == FALSE and not args):
            return False
        if not pred.startswith(theory.neg_prefix) and ids.get((pred, args), mentioned) < mentioned:
            return True
        return ids.get((theory.neg_prefix + pred, args), mentioned) < mentioned


class AtomNumbering:
    """The atoms of a theory as numbers, and its clauses as arrays of them.

    Atoms are numbered in two ranges.  Below ``named`` are the atoms of the look-up ``ids``:
    those the theory mentions and the NAB atoms of components it does not.  From ``named``
    on are the complements nothing mentions (``not_p`` of a mentioned ``p``, AB of a NAB):
    each exists only as a number and its complement's, so that the numbering never builds
    a key or a dictionary entry for atoms the model does not mention, which are most of them.
    """

    def __init__(self, theory: Theory) -> None:
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
        self.ab_ids = list(map(self.complement.__getitem__, self.all_nab))  # AB(c) = ¬NAB(c)
        self.nab_atoms = frozenset(self.all_nab)
        self.ab_atoms = frozenset(self.ab_ids)
        self.nab_id = dict(zip(comps, self.all_nab, strict=True))
        self.ab_id = dict(zip(comps, self.ab_ids, strict=True))
        # assumption atom (NAB or AB) -> its component
        self.component = dict(zip(self.all_nab, comps, strict=True))
        self.component.update(zip(self.ab_ids, comps, strict=True))
        self.head = heads
        self.body = bodies
        self.known = KnownAtoms(self)

    @property
    def keys(self) -> list[Key]:
        """Every atom's (predicate, args), by number: the unnamed complements spelt out
        (built on first use: error messages and tests read it, checks never do)."""
        if self._keys is None:
            keys = list(self.ids)
            other = self.complement_predicate
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
        other_of = {p: self.complement_predicate(p) for p in dict.fromkeys(map(_first, ids))}
        if any(self.complement_predicate(q) != p for p, q in other_of.items()):
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
                wanted = (none, ()) if a == false_id else (self.complement_predicate(pred), args)
                found = ids.get(wanted, -1)
                if found < 0 and wanted[0]:
                    found = _intern(ids, wanted)
                    keys.append(wanted)
                complement.append(found)
            done = len(complement)
        self.ids = ids
        return complement

    def complement_predicate(self, pred: str) -> str:
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
            other = self.complement_predicate(pred)
            if self.complement_predicate(other) == pred:
                atom = self.ids.get((other, args))
                if atom is not None and self.complement[atom] >= self.named:
                    return self.complement[atom]
        return found

    def is_ab(self, assumption: int) -> bool:
        """Is the assumption atom AB(c), not NAB(c)?"""
        return self.ab_id[self.component[assumption]] == assumption

    def atom_id(self, atom: Atom) -> int | None:
        return self.number((atom.predicate, atom.args))

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

    def observed(self, observations: Sequence[Literal]) -> list[int]:
        """Θ as atom numbers (RacError RAC040 for an unknown atom)."""
        # C loops over the whole Θ, on a table of the observable atoms alone: tens of
        # thousands of observations per diagnosis, where a Python loop per literal on the
        # table of every atom was a fifth of a fan-in's diagnosis at 20,000 components.
        if not isinstance(observations, Sequence):  # read three times below
            observations = list(observations)
        found: list[int | None] = list(map(self._observable.get, map(_key_of, observations)))
        complement = self.complement
        for k in compress(count(), map(not_, map(_positive_of, observations))):
            i = found[k]
            if i is not None:
                found[k] = complement[i]
        for k in compress(count(), map(is_, found, repeat(None))):
            found[k] = self.literal_atom(observations[k])  # another atom, or RAC040
        return cast(list[int], found)

    @functools.cached_property
    def _observable(self) -> dict[Key, int]:
        """The theory's props whose predicate an observation names as it is (not AB, NAB,
        false or one with the negation prefix, which :meth:`literal_id` looks at more
        closely) -> their numbers: a table a third the size of ``ids``."""
        theory, ids = self.theory, self.ids
        excluded = {theory.ab, theory.nab, FALSE}
        found = {}
        for atom in theory.props:
            key = (atom.predicate, atom.args)
            i = ids.get(key)
            if (
                i is not None
                and key[0] not in excluded
                and not key[0].startswith(theory.neg_prefix)
            ):
                found[key] = i
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

    def assignment(self, bad: frozenset[str], strong: bool) -> list[int]:
        """AB(c) for c in bad (when ``strong``) and NAB(c) for every other component."""
        seeds = [a for a in self.all_nab if self.component[a] not in bad]
        if strong:
            seeds.extend(self.ab_id[c] for c in sorted(bad))
        return seeds
