"""What ``racc record`` writes beside the bag (§9.1.1): the computation graph and the
properties CSV, in the shapes ``racc learn --graph`` and ``--properties`` read."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import yaml

from rac.learn.graph import INFRASTRUCTURE_TOPICS

RACC_PREFIX = "/racc_"  # racc's own nodes (runtime, recorder, tools) are not the robot's


def robot_node(name: str) -> bool:
    return not name.startswith(RACC_PREFIX) and not name.startswith("/rosout")


def graph_yaml(
    publishers: Sequence[tuple[str, Sequence[str]]],
    subscribers: Sequence[tuple[str, Sequence[str]]],
    ignore: Iterable[str] = (),
) -> str:
    """The master's getSystemState as the ``--graph`` YAML (nodes with their topics)."""
    skip = {n.rstrip("/") for n in ignore}
    nodes: dict[str, dict[str, set[str]]] = {}
    for key, pairs in (("publications", publishers), ("subscriptions", subscribers)):
        for topic, names in pairs:
            if topic in INFRASTRUCTURE_TOPICS:
                continue
            for name in names:
                if name in skip or not robot_node(name):
                    continue
                entry = nodes.setdefault(name, {"publications": set(), "subscriptions": set()})
                entry[key].add(topic)
    data = {
        "nodes": {
            name: {k: sorted(v) for k, v in sorted(entry.items())}
            for name, entry in sorted(nodes.items())
        }
    }
    return "# Computation graph recorded by racc record (racc learn --graph).\n" + yaml.safe_dump(
        data, sort_keys=False
    )


def properties_rows(t: float, samples: Iterable[tuple[str, float, float]]) -> list[str]:
    """CSV lines ``time,node,cpu,mem`` for (node, cpu %, mem bytes) samples at ``t``."""
    return [f"{t:.3f},{node},{cpu:.3f},{mem:.0f}" for node, cpu, mem in samples]
