"""Which diagnosis to repair (§4.3.5, §8.4).

``minimal`` (the default) plans one repair covering every component of the
minimum-cardinality diagnoses: for §8.4, where {jaguar} and {jaguar_node}
explain a silent /pose equally well, it power-cycles jaguar and restarts
jaguar_node in one plan instead of repairing one, observing, and repairing
again.  ``first`` repairs the first diagnosis only, as the dissertation does.
"""

from __future__ import annotations

STRATEGIES = ("minimal", "first")


def choose_bad(diagnoses: tuple[tuple[str, ...], ...], strategy: str) -> tuple[str, ...]:
    """The components to repair (sorted); ``diagnoses`` fewest first, as diagnose() gives them."""
    if not diagnoses:
        return ()
    if strategy == "first":
        return tuple(sorted(diagnoses[0]))
    if strategy != "minimal":
        raise ValueError(f"unknown strategy {strategy!r}; choose from {', '.join(STRATEGIES)}")
    fewest = min(len(d) for d in diagnoses)
    return tuple(sorted({c for d in diagnoses if len(d) == fewest for c in d}))
