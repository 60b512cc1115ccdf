"""What ``racc record`` writes beside a bag, read for learning and evaluation: the properties
CSV (time, node, cpu, mem) and the graph file (nodes, their topics and machines)."""

from __future__ import annotations

from pathlib import Path

from rac.learn.graph import Graph, parse_graph
from rac.learn.properties import parse_properties
from rac.load.files import read_text
from rac.load.kinds import GRAPH, PROPERTIES, check_kind


def load_properties(path: str | Path) -> dict[str, dict[str, list[float]]]:
    """node -> property (cpu, mem) -> samples (RAC082 for a malformed file)."""
    check_kind(path, PROPERTIES, "RAC082")
    return parse_properties(read_text(path), str(path))


def load_graph(path: str) -> Graph:
    check_kind(path, GRAPH, "RAC081")
    return parse_graph(read_text(path), path)
