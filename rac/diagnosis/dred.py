"""Delete and rederive (DRed): whether a candidate diagnosis is consistent, checked on the
all-normal closure in the time its components' consequences take."""

from __future__ import annotations

from collections import ChainMap

from rac.diagnosis.propagation import ASSUMED, Base, Full, Propagation, Run


def check(
    propagation: Propagation, base: Base, full: Full, bad: frozenset[str], strong: bool
) -> Run:
    """Is AB(bad) ∪ NAB(COMPS∖bad) consistent with Θ?  Incremental on ``full``.

    Delete and rederive (DRed): drop everything that NAB(bad) supported in ``full``,
    restore what still has a derivation, then add AB(bad).  The cost is the cone of
    ``bad`` in the model, not the model: a candidate diagnosis is checked in the time
    its components' consequences take.
    """
    true_f, missing_f, base_true = full.true, full.missing, base.true
    occurs, head = propagation.occurs, propagation.head
    complement, false_id = propagation.complement, propagation.false_id
    nab_id, ab_id = propagation.numbering.nab_id, propagation.numbering.ab_id
    why_f = full.why
    # 1. over-delete the consequences of the retracted assumptions
    lost: set[int] = set()
    stack = [nab_id[c] for c in sorted(bad) if not base_true[nab_id[c]]]
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
    by_head = propagation.by_head
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
        for k in by_head[h]:
            restorable = missing_f[k] == 0 and k not in lost_in_body and h in lost
            if restorable and make_true(h, k):
                return Run(clash, ChainMap(why, why_f))
    if strong:
        for c in sorted(bad):
            a = ab_id[c]
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
