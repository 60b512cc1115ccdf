"""What ``racc record`` writes beside the bag (§9.1.1): the computation graph and the
properties CSV, in the shapes ``racc learn --graph`` and ``--properties`` read."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence

import psutil
import yaml

from rac.learn.graph import Exclusions
from rac.runtime.procs import Resolved, as_found

DEFAULT_EXCLUSIONS = Exclusions()


def robot_node(name: str) -> bool:
    """Whether a node is the robot's under the default exclusions (racc's own nodes and
    ROS's tool nodes are not)."""
    return DEFAULT_EXCLUSIONS.node(name)


def graph_yaml(
    publishers: Sequence[tuple[str, Sequence[str]]],
    subscribers: Sequence[tuple[str, Sequence[str]]],
    ignore: Iterable[str] = (),
    exclusions: Exclusions = DEFAULT_EXCLUSIONS,
    hosts: Mapping[str, str] | None = None,
) -> str:
    """The master's getSystemState as the ``--graph`` YAML (nodes with their topics, and
    the host each runs on when ``hosts`` knows it: ROS 1's lookupNode URIs), without what
    ``exclusions`` leaves out."""
    hosts = hosts or {}
    skip = {n.rstrip("/") for n in ignore}
    owners = {topic: names for topic, names in publishers}
    nodes: dict[str, dict[str, set[str]]] = {}
    for key, pairs in (("publications", publishers), ("subscriptions", subscribers)):
        for topic, names in pairs:
            if not exclusions.topic(topic, owners.get(topic, ())):
                continue
            for name in names:
                if name in skip or not exclusions.node(name):
                    continue
                entry = nodes.setdefault(name, {"publications": set(), "subscriptions": set()})
                entry[key].add(topic)
    data = {
        "nodes": {
            name: {
                **{k: sorted(v) for k, v in sorted(entry.items())},
                **({"host": hosts[name]} if name in hosts else {}),
            }
            for name, entry in sorted(nodes.items())
        }
    }
    return "# Computation graph recorded by racc record (racc learn --graph).\n" + yaml.safe_dump(
        data, sort_keys=False
    )


def properties_rows(t: float, samples: Iterable[tuple[str, float, float]]) -> list[str]:
    """CSV lines ``time,node,cpu,mem`` for (node, cpu %, mem bytes) samples at ``t``."""
    return [f"{t:.3f},{node},{cpu:.3f},{mem:.0f}" for node, cpu, mem in samples]


class PropertySampler:
    """cpu and memory of the robot's nodes for the properties CSV.  ``resolve(node)``
    gives the node's proven local process (:class:`rac.runtime.placement.Found`; None or no
    pid: none here); a process is asked for its cpu from the second sample on (psutil
    measures between two calls)."""

    def __init__(self, resolve: Callable[[str], Resolved]) -> None:
        self.resolve = resolve
        self._procs: dict[str, psutil.Process] = {}

    def rows(self, now: float, nodes: Iterable[str]) -> list[str]:
        samples = []
        for node in sorted(set(nodes)):
            proc = self._procs.get(node)
            if proc is None or not proc.is_running():
                found = as_found(self.resolve(node))
                if found is None or found.pid is None:
                    continue
                try:
                    proc = self._procs[node] = psutil.Process(found.pid)
                    proc.cpu_percent(None)
                except psutil.Error:
                    pass
                continue
            try:
                samples.append(
                    (node.lstrip("/"), proc.cpu_percent(None), float(proc.memory_info().rss))
                )
            except psutil.Error:
                self._procs.pop(node, None)
        return properties_rows(now, samples)
