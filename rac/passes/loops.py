"""Feedback loops in the data flow, and the loop rule that lets a healthy loop run.

The publication clause ``NAB(n), ok(i)… -> ok(τ)`` derives ``ok(τ)`` from its inputs.  Around
a loop (odom → scan matcher → corrected pose → base driver → odom) each ``ok`` then waits for
another that waits for it, so no clause ever fires: ``not ok(odom)`` would be consistent with
every component healthy.  A fault cannot come out of nothing, though: a topic of a loop can
only go bad when a component on the loop, or an input from outside it, is bad.

**The loop rule.**  Take a set R of at least two topics of one strongly connected component of
the topic graph (an edge ``i → τ`` for each ``publishes τ from …, i``), and for each topic of R
one publication of it with an input in R, such that these publications connect R strongly.
Then for every τ in R::

    NAB(n)… and NAB(h)… of the chosen publications (h switchable and driven by n),
    ok(i)… for their inputs outside R  ->  ok(τ)

With one publisher per topic and a simple cycle this is exactly one clause per topic: all of the
loop's nodes healthy and all of its external inputs ok.  Enumerating every such R makes the
rules exact (the ok topics are the greatest fixed point of the publication clauses, as the
brute-force test checks); a loop with more than ``EXACT_LIMIT`` candidate sets gets only the
rule for the whole loop, which is sound but fires only when all of the loop is healthy
(warning RAC105).
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass

from rac.ir import Model
from rac.logic import Atom, Clause, mangle

EXACT_LIMIT = 4096  # candidate (subset, choice) pairs per loop before falling back


@dataclass(frozen=True, slots=True)
class Pub:
    """One ``publishes topic from inputs`` of one node, with its switchable hardware."""

    node: str
    topic: str
    inputs: tuple[str, ...]
    hardware: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Loop:
    """A strongly connected set of topics (two or more) and the publications inside it."""

    topics: tuple[str, ...]  # in declaration order
    pubs: tuple[Pub, ...]  # publications of a loop topic with an input in the loop

    @property
    def nodes(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(p.node for p in self.pubs))

    @property
    def external_inputs(self) -> tuple[str, ...]:
        inside = set(self.topics)
        return tuple(dict.fromkeys(i for p in self.pubs for i in p.inputs if i not in inside))

    def describe(self) -> str:
        return " → ".join((*self.topics, self.topics[0]))


def publications(model: Model) -> tuple[Pub, ...]:
    switchable = {h.name.value for h in model.hardware if h.switchable}
    return tuple(
        Pub(
            node.name.value,
            pub.topic.value,
            tuple(i.value for i in pub.affected_by),
            tuple(h.value for h in node.drives if h.value in switchable),
        )
        for node in model.nodes
        for pub in node.publishes
    )


def topic_graph(model: Model) -> dict[str, list[str]]:
    """Topics, each with its successors: an edge input → output for every ``publishes
    output from input`` (an input or output nobody declared is a vertex too)."""
    graph: dict[str, list[str]] = {t.name.value: [] for t in model.topics}
    setdefault = graph.setdefault
    for node in model.nodes:
        for pub in node.publishes:
            topic = pub.topic.value
            setdefault(topic, [])
            for i in pub.affected_by:
                setdefault(i.value, []).append(topic)
    return graph


def strongly_connected(graph: Mapping[str, Iterable[str]]) -> list[set[str]]:
    """The strongly connected components of ``graph`` (vertex -> successors; every successor
    is a vertex), by Tarjan's algorithm without recursion: linear, and no graph library to
    import or to build on a model of ten thousand nodes."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[set[str]] = []
    for root in graph:
        if root in index:
            continue
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        work = [(root, iter(graph[root]))]
        while work:
            vertex, successors = work[-1]
            for succ in successors:
                if succ not in index:
                    index[succ] = low[succ] = len(index)
                    stack.append(succ)
                    on_stack.add(succ)
                    work.append((succ, iter(graph[succ])))
                    break
                if succ in on_stack and index[succ] < low[vertex]:
                    low[vertex] = index[succ]
            else:
                work.pop()
                if work and low[vertex] < low[work[-1][0]]:
                    low[work[-1][0]] = low[vertex]
                if low[vertex] == index[vertex]:
                    component: set[str] = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.add(member)
                        if member == vertex:
                            break
                    components.append(component)
    return components


def find_loops(model: Model) -> tuple[Loop, ...]:
    """Every feedback loop of the data flow, in the order of its first declared topic."""
    cached = model._memo.get("loops")
    if isinstance(cached, tuple):
        return cached
    # A topic cannot feed itself (RAC021): a loop has two topics or more.
    found = [scc for scc in strongly_connected(topic_graph(model)) if len(scc) > 1]
    if not found:  # the usual case: no publication needs looking at again
        model._memo["loops"] = ()
        return ()
    order = {t.name.value: k for k, t in enumerate(model.topics)}
    pubs = publications(model)
    loops = []
    for scc in found:
        topics = tuple(sorted(scc, key=lambda t: (order.get(t, len(order)), t)))
        inside = [p for p in pubs if p.topic in scc and any(i in scc for i in p.inputs)]
        loops.append(Loop(topics, tuple(inside)))
    result = tuple(sorted(loops, key=lambda lp: order.get(lp.topics[0], len(order))))
    model._memo["loops"] = result
    return result


def _count_choices(loop: Loop) -> int:
    per_topic = [sum(p.topic == t for p in loop.pubs) + 1 for t in loop.topics]
    return functools.reduce(lambda a, b: a * b, per_topic, 1)


def is_exact(loop: Loop) -> bool:
    """Whether the loop is small enough for the exact rule set."""
    return _count_choices(loop) <= EXACT_LIMIT


def supports(loop: Loop) -> Iterator[tuple[tuple[str, ...], tuple[Pub, ...]]]:
    """Every (R, chosen publications) whose publications connect R strongly."""
    if not is_exact(loop):
        yield loop.topics, loop.pubs
        return
    for size in range(2, len(loop.topics) + 1):
        for subset in itertools.combinations(loop.topics, size):
            inside = set(subset)
            options = [
                [p for p in loop.pubs if p.topic == t and any(i in inside for i in p.inputs)]
                for t in subset
            ]
            if any(not o for o in options):
                continue
            for choice in itertools.product(*options):
                graph: dict[str, list[str]] = {t: [] for t in subset}
                for p in choice:
                    for i in p.inputs:
                        if i in inside:
                            graph[i].append(p.topic)
                if len(strongly_connected(graph)) == 1:
                    yield subset, tuple(choice)


def _nab(name: str) -> Atom:
    return Atom("NAB", (mangle(name),))


def _ok(name: str) -> Atom:
    return Atom("ok", (mangle(name),))


def loop_clauses(model: Model) -> Iterator[Clause]:
    """The loop rule's clauses for every loop of the model (see the module docstring)."""
    for loop in find_loops(model):
        for subset, chosen in supports(loop):
            inside = set(subset)
            body = [_nab(p.node) for p in chosen]
            body += [_nab(h) for p in chosen for h in p.hardware]
            body += [_ok(i) for p in chosen for i in p.inputs if i not in inside]
            unique = tuple(dict.fromkeys(body))
            for topic in subset:
                yield Clause(unique, _ok(topic))
