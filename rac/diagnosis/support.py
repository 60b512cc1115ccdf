"""Which assumptions a contradiction rests on: the support trace, the assumptions every
derivation needs, and minimal conflicts.

One trace serves the support of a check and the search's singleton test, another the
one-derivation label of a whole closure; :func:`necessary` finds the assumptions in every
derivation of every contradiction in one pass, and :func:`minimal_conflict` shrinks a
conflict with it.
"""

from __future__ import annotations

from collections import ChainMap
from collections.abc import Iterable, Mapping, Sequence

from rac.diagnosis.propagation import ASSUMED, Base, Full, Propagation

# A conflict this small is shrunk by deletion alone: a test per atom costs less than a pass of
# necessary over the whole closure.
_DELETION_ONLY = 4


def assumptions_behind(
    atoms: Iterable[int],
    why: Mapping[int, int],
    body: Sequence[Sequence[int]],
    limit: int | None = None,
) -> set[int]:
    """The assumption atoms ``atoms`` were derived from, following each atom's clause in
    ``why`` back to atoms assumed (:data:`ASSUMED`) or true in the base (absent from ``why``).

    With ``limit`` the trace stops once that many are found.  A ``why`` that is a
    :class:`~collections.ChainMap` of two dictionaries (:func:`rac.diagnosis.dred.check`'s)
    is read map by map: its own ``get`` runs in Python, once per atom of a trace as long as
    the model.
    """
    return _trace(atoms, why, body, limit)


def assumptions_of_one_derivation(
    atoms: Iterable[int],
    closure: Full,
    body: Sequence[Sequence[int]],
    by_head: Sequence[Sequence[int]],
) -> frozenset[int] | None:
    """:func:`assumptions_behind` of ``atoms`` in ``closure`` when every atom they were derived
    from has one derivation (no other clause of it fired; no clause at all when it was
    assumed), which makes those assumptions needed by every derivation; None otherwise.

    The trace of a contradiction in a whole closure: as long as the model (a chain, a
    fan-in), so the atoms met are marked in a byte per atom, not kept in a set, whose
    table at 60,000 atoms no longer fits a core's cache.
    """
    why, missing = closure.why, closure.missing
    find = why.get
    found: list[int] = []
    seen = bytearray(len(by_head))
    stack = list(atoms)
    while stack:
        a = stack.pop()
        if seen[a]:
            continue
        seen[a] = 1
        k = find(a)
        if k is None:  # true in the base: follows from Θ alone
            continue
        deriving = by_head[a]  # no clause for an assumption, one for a chain's link
        several = deriving and (k == ASSUMED or len(deriving) > 1)
        if several and any(missing[j] == 0 for j in deriving if j != k):
            return None  # a second derivation
        if k == ASSUMED:
            found.append(a)
        else:
            stack.extend(reversed(body[k]))
    return frozenset(found)


def _trace(
    atoms: Iterable[int],
    why: Mapping[int, int],
    body: Sequence[Sequence[int]],
    limit: int | None,
) -> set[int]:
    """:func:`assumptions_behind`: depth first, a clause's body pushed last atom first, so
    that a clause's own assumptions are met before the atoms it was derived from (a limit
    is reached without walking a chain to its start)."""
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
        if k == ASSUMED:
            found.add(a)
        else:
            stack.extend(reversed(body[k]))
    return found


def necessary(
    propagation: Propagation,
    base: Base,
    assumed: Sequence[int],
    candidates: Sequence[int],
    closure: Full | None = None,
) -> frozenset[int]:
    """The ``candidates`` without which facts ∪ Θ ∪ ``assumed`` is consistent: the
    assumptions in every derivation of every contradiction, in one pass.

    ``assumed`` must contradict Θ; ``closure`` is :meth:`Propagation.closure` of ``base`` under
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
        closure = propagation.closure(base, assumed)
    if len(closure.clashes) == 1:
        traced = assumptions_of_one_derivation(
            closure.clashes[0], closure, propagation.body, propagation.by_head
        )
        if traced is not None:
            return frozenset(a for a in candidates if a in traced)
    return _necessary_by_masks(propagation, closure, candidates)


def _necessary_by_masks(
    propagation: Propagation, closure: Full, candidates: Sequence[int]
) -> frozenset[int]:
    """:func:`necessary` by the bit masks of its docstring."""
    true, missing, why = closure.true, closure.missing, closure.why
    bit = {a: 1 << i for i, a in enumerate(candidates)}
    every = (1 << len(candidates)) - 1
    body, by_head = propagation.body, propagation.by_head
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
    complement, false_id = propagation.complement, propagation.false_id
    common = every
    for a in why:
        c = complement[a]
        if a == false_id:
            common &= mask[a]
        elif c >= 0 and true[c]:
            common &= mask[a] | mask.get(c, 0)
    return frozenset(a for a in candidates if common & bit[a])


def minimal_conflict(
    propagation: Propagation,
    base: Base,
    conflict: frozenset[int],
    needed_under: dict[frozenset[int], frozenset[int]] | None = None,
    closure: Full | None = None,
) -> frozenset[int]:
    """Shrink a set of assumption atoms that contradicts Θ to a subset-minimal one.

    Deletion-based: drop one atom at a time and keep the (traced) smaller conflict when
    the rest still contradicts.  Inconsistency is monotone in the assumptions (Horn), so
    an atom found necessary stays necessary in every subset: the atoms :func:`necessary`
    finds are never tested, and when they contradict Θ by themselves they are the only
    minimal conflict inside ``conflict`` (what deletion would have found, one test each).
    ``needed_under`` gets ``conflict`` -> those atoms, when they were computed: the
    members of any set of candidates within ``conflict`` that every contradiction under
    ``conflict`` needs, without another pass.  ``closure`` is
    :meth:`Propagation.closure` of ``base`` under ``conflict`` when the caller has it.
    """
    kept = sorted(conflict)
    needed: frozenset[int] = frozenset()
    if len(kept) > _DELETION_ONLY:
        needed = necessary(propagation, base, kept, kept, closure)
        if needed_under is not None:
            needed_under[conflict] = needed
        if len(needed) == len(kept):  # all of the conflict, which contradicts Θ
            return needed
        if needed and propagation.run(base, sorted(needed)).clash:
            return needed
    i = 0
    while i < len(kept):
        if kept[i] in needed:  # the rest is consistent without it: kept as deletion would
            i += 1
            continue
        trial = kept[:i] + kept[i + 1 :]
        result = propagation.run(base, trial)
        if not result.clash:
            i += 1
            continue
        support = assumptions_behind(result.clash, result.why, propagation.body)
        kept = kept[:i] + [a for a in kept[i + 1 :] if a in support]
    return frozenset(kept)
