"""Which diagnosis to repair (§4.3.5, §8.4).

``minimal`` (the default) plans one repair covering every component of the
minimum-cardinality diagnoses: for §8.4, where {jaguar} and {jaguar_node}
explain a silent /pose equally well, it power-cycles jaguar and restarts
jaguar_node in one plan instead of repairing one, observing, and repairing
again.  A minimum-cardinality diagnosis that blames hardware no action can
repair is left out of that union while another one can be repaired: restarting
p2os is worth trying when {p2os} and {pioneer_base} explain a fault equally well.
``first`` repairs the first diagnosis only, as the dissertation does.
"""

from __future__ import annotations

from collections.abc import Callable

STRATEGIES = ("minimal", "first")


def choose_bad(
    diagnoses: tuple[tuple[str, ...], ...],
    strategy: str,
    repairable: Callable[[str], bool] = lambda component: True,
) -> tuple[str, ...]:
    """The components to repair (sorted); ``diagnoses`` fewest first, as diagnose() gives them."""
    if not diagnoses:
        return ()
    if strategy == "first":
        return tuple(sorted(diagnoses[0]))
    if strategy != "minimal":
        raise ValueError(f"unknown strategy {strategy!r}; choose from {', '.join(STRATEGIES)}")
    fewest = min(len(d) for d in diagnoses)
    smallest = [d for d in diagnoses if len(d) == fewest]
    fixable = [d for d in smallest if all(repairable(c) for c in d)]
    return tuple(sorted({c for d in (fixable or smallest) for c in d}))
