"""Layers by data flow: the order in which a drawing lays its nodes out, sources first.

A robot's graph has loops (the odometry loop through the base driver, a planner and the
task manager asking each other), and a layered drawing needs an order without them.  Where
a loop is broken decides which arrows run backwards, so the place is chosen, not left to
Graphviz's depth-first search (docs/diagrams.md, "Layers"):

1. the sources come first: the drivers (nodes that drive hardware) and the nodes nothing
   drawn feeds (players, map servers);
2. then the greedy order of Eades, Lin and Smyth (1993), which keeps as few arrows
   backwards as it can: a node nothing left feeds goes next, a node that feeds nothing left
   goes last, and otherwise the node whose outputs most outnumber its inputs goes next
   (ties in declaration order);
3. an arrow from a later node to an earlier one is a feedback arrow: it is drawn, but
   against the layering (``dir=back``), so it does not drag the earlier node after the later.

So a command into a driver (``/cmd_vel`` into the base driver) is where the odometry loop
turns back: the driver stays with the sensors, its command returns to it.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from rac.ir import Model


def flow_order(
    nodes: Sequence[str], edges: Iterable[tuple[str, str]], prefer: Iterable[str] = ()
) -> list[str]:
    """``nodes`` ordered so that as few ``edges`` as the greedy heuristic can manage run from
    a later node to an earlier one.  Where a loop must be broken, a node of ``prefer`` (a
    driver) goes first.  Deterministic: ties follow ``nodes``."""
    index = {n: i for i, n in enumerate(nodes)}
    # dicts as ordered sets: a set's order changes with the hash seed, and so would the
    # drawing
    succ: dict[str, dict[str, None]] = {n: {} for n in nodes}
    pred: dict[str, dict[str, None]] = {n: {} for n in nodes}
    for a, b in edges:
        if a != b and a in index and b in index:
            succ[a][b] = None
            pred[b][a] = None
    preferred = set(prefer)
    left = dict.fromkeys(nodes)  # in declaration order
    sinks = deque(n for n in nodes if not succ[n])
    starts = deque(n for n in nodes if not pred[n])
    head: list[str] = []
    tail: list[str] = []

    def remove(n: str) -> None:
        del left[n]
        for m in succ[n]:
            pred[m].pop(n, None)
            if not pred[m]:
                starts.append(m)
        for m in pred[n]:
            succ[m].pop(n, None)
            if not succ[m]:
                sinks.append(m)

    while left:
        while sinks or starts:
            while sinks:
                n = sinks.popleft()
                if n in left:
                    tail.append(n)
                    remove(n)
            while starts and not sinks:
                n = starts.popleft()
                if n in left:
                    head.append(n)
                    remove(n)
        if left:  # a loop: break it before the driver in it, or the most giving node
            best = max(left, key=lambda n: (n in preferred, len(succ[n]) - len(pred[n]), -index[n]))
            head.append(best)
            remove(best)
    return head + tail[::-1]


def feedback(order: Sequence[str], edges: Iterable[tuple[str, str]]) -> set[tuple[str, str]]:
    """The edges that run against ``order``: the loops' feedback arrows."""
    position = {n: i for i, n in enumerate(order)}
    return {
        (a, b) for a, b in edges if a in position and b in position and position[b] < position[a]
    }


@dataclass(frozen=True, slots=True)
class Layout:
    """The layering of one drawing: its first layer and its feedback arrows."""

    sources: list[str]
    back: set[tuple[str, str]]


def lay_out(
    model: Model,
    nodes: Sequence[str],
    boxes: Sequence[str],
    edges: Iterable[tuple[str, str]],
    hubs: Iterable[str] = (),
) -> Layout:
    """The layering of drawn ``nodes`` and topic ``boxes`` (drawn ids) joined by ``edges``;
    ``hubs`` are drawn beside the others and take no part (rac.targets.diagram.flow)."""
    left_out = set(hubs)
    vertices = [n for n in nodes if n not in left_out] + list(boxes)
    kept = [(a, b) for a, b in edges if a not in left_out and b not in left_out]
    fed = {b for a, b in edges if a != b}
    # the first layer: the nodes nothing drawn feeds and that drive hardware or read
    # nothing at all (sensor drivers, players, map servers); a node whose inputs are all
    # folded (a diagnostic aggregator) is placed by its outputs
    starts = {n.name.value for n in model.nodes if n.drives or not n.subscribes}
    sources = [n for n in nodes if n not in left_out and n not in fed and n in starts]
    drivers = [n.name.value for n in model.nodes if n.drives]
    order = flow_order(vertices, kept, drivers)
    return Layout(sources, feedback(order, kept))


def first_layer(model: Model, sources: Iterable[str], drawn: Iterable[str]) -> list[str]:
    """What stands in the first column: a source's hardware (the driver follows it, as in
    Figure 3.1), or the source itself when it drives nothing drawn."""
    present = set(drawn)
    drives = {n.name.value: [h.value for h in n.drives] for n in model.nodes}
    first: list[str] = []
    for source in sources:
        devices = [h for h in drives.get(source, []) if h in present]
        first += devices or [source]
    return list(dict.fromkeys(first))
