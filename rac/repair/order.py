"""Put a repair plan's start steps in data-flow order where the domain allows it.

A planner returns any valid order; a user starting a robot expects the nodes that feed
others to start first (a subscriber that starts before its publisher waits, or warns).
The only orderings the repair domain imposes between start steps are: a device is powered up
before its drivers start, and each component's own steps keep their order.  Every other
step (stop_node, shutdown) stays where the planner put it relative to all others.
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence
from typing import TYPE_CHECKING

from rac.ir import Model
from rac.logic import mangle
from rac.repair.system import RepairSystem

if TYPE_CHECKING:
    import networkx as nx

Step = tuple[str, ...]
_STARTS = ("start_node", "power_up")


def flow_ranks(model: Model) -> dict[str, int]:
    """Each node (mangled) -> its depth in the data flow: publishers before subscribers;
    the nodes of a feedback loop share one depth."""
    # networkx is heavy (8 MiB, 0.3 s): loaded when a plan is ordered, not by every racc
    # process that imports the repair package (the observer host and the engine do).
    import networkx as nx

    graph: nx.DiGraph = nx.DiGraph()
    graph.add_nodes_from(mangle(n.name.value) for n in model.nodes)
    publishers: dict[str, list[str]] = {}
    for n in model.nodes:
        for topic in n.published_topics:
            publishers.setdefault(topic, []).append(mangle(n.name.value))
    for n in model.nodes:
        for sub in n.subscribes:
            for p in publishers.get(sub.value, []):
                if p != mangle(n.name.value):
                    graph.add_edge(p, mangle(n.name.value))
    dag = nx.condensation(graph)
    depth: dict[int, int] = {}
    for scc in nx.topological_sort(dag):
        depth[scc] = max((depth[p] + 1 for p in dag.predecessors(scc)), default=0)
    return {n: depth[dag.graph["mapping"][n]] for n in graph.nodes}


def dataflow_order(plan: Sequence[Step], system: RepairSystem, model: Model) -> tuple[Step, ...]:
    """``plan`` reordered: among start steps, data-flow depth first, then the planner's order."""
    ranks = flow_ranks(model)
    drives = set(system.drives)

    def related(a: Step, b: Step) -> bool:
        x, y = a[1], b[1]
        return x == y or (x, y) in drives or (y, x) in drives

    def free(a: Step, b: Step) -> bool:
        return a[0] in _STARTS and b[0] in _STARTS and not related(a, b)

    def rank(step: Step) -> int:
        if step[0] == "start_node":
            return ranks.get(step[1], 0)
        if step[0] == "power_up":  # just before its first driver
            return min((ranks.get(n, 0) for n in system.drivers_of(step[1])), default=0)
        return 0

    before: list[set[int]] = [set() for _ in plan]
    for j in range(len(plan)):
        for i in range(j):
            if not free(plan[i], plan[j]):
                before[j].add(i)
    waiting = [len(b) for b in before]
    after: list[list[int]] = [[] for _ in plan]
    for j, b in enumerate(before):
        for i in b:
            after[i].append(j)
    ready = [(rank(plan[i]), i) for i in range(len(plan)) if not waiting[i]]
    heapq.heapify(ready)
    out: list[Step] = []
    while ready:
        _, i = heapq.heappop(ready)
        out.append(tuple(plan[i]))
        for j in after[i]:
            waiting[j] -= 1
            if not waiting[j]:
                heapq.heappush(ready, (rank(plan[j]), j))
    return tuple(out)
