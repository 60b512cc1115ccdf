"""What one drawing holds before it is written as DOT: the view asked for, the items and
arrows, the legend keys used and the caption's notes; the styles of each kind of item."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from rac.targets.coverage import Health, Marks, Watch

COLOURS = {
    "watched": "#1f4e79",  # a topic an observer watches: the dissertation's blue
    "unwatched": "#8a8a8a",  # grey: nothing watches it
    "undetected": "#c62828",  # red outline: a fault here goes unseen
    "faulty": "#e53935",  # in every minimal diagnosis
    "suspect": "#ffb74d",  # in some minimal diagnosis
    "bad": "#c62828",  # an observer reads bad
    "good": "#2e7d32",  # every observer that reported reads good
    "focus": "#1565c0",
}

# Each node style: its attributes in the drawing.
STYLE = {
    "hardware": 'shape=box, style="filled", fillcolor="#ffffff", penwidth=1.2',
    "sn": 'fillcolor="#555555", fontcolor="#ffffff"',
    "hn": 'fillcolor="#bdbdbd"',
    "n": 'fillcolor="#ffffff"',
    "topic": 'shape=box, style="rounded,filled", fillcolor="#e8f0f8", color="#7f9fbf", '
    'fontsize=9, height=0.22, margin="0.05,0.02"',
    "loose_topic": 'shape=box, style="rounded,filled,dashed", fillcolor="#e8f0f8", '
    'color="#7f9fbf", fontsize=9, height=0.22, margin="0.05,0.02"',
    "group": 'shape=box, style="rounded,filled", fillcolor="#f4f6f8", color="#607d8b", fontsize=10',
}
EDGE_STYLE = {
    "hardware_link": 'style=dotted, dir=none, penwidth=1.4, color="#555555"',
    "wire": "",
    "publish": "arrowhead=none",
    "subscribe": "",
    "group_flow": 'color="#607d8b"',
}

CLASS_NAMES = {
    "sn": "driver of switchable hardware (SN)",
    "hn": "hardware driver (HN)",
    "n": "software node (N)",
}


@dataclass(frozen=True, slots=True)
class View:
    """Which diagram of a model to draw (docs/diagrams.md)."""

    everything: bool = False  # fold nothing, never summarise
    focus: str | None = None  # a node, hardware or topic name: draw its neighbourhood
    depth: int = 1  # node-to-node hops around the focus, upstream and downstream
    summary: bool = False  # one box per namespace
    # Per component (as named or mangled), the fault modes no observer detects
    # (rac.analysis.undetected); None when the analysis was not run.
    undetected: tuple[tuple[str, tuple[str, ...]], ...] | None = None
    health: Health | None = None


@dataclass(slots=True)
class Item:
    """A node statement: raw id, attributes, label (already DOT: quoted or <HTML>), tooltip."""

    id: str
    attrs: str
    label: str
    tooltip: str
    cluster: str = ""


@dataclass(slots=True)
class Scene:
    """Everything one drawing holds, before it is written as DOT."""

    items: list[Item] = field(default_factory=list)
    edges: list[str] = field(default_factory=list)  # finished edge statements
    legend: dict[str, None] = field(default_factory=dict)  # legend keys used, in order
    notes: list[str] = field(default_factory=list)  # caption lines (plain text)
    relations: list[str] = field(default_factory=list)  # the related pairs, as written
    prefix: str = ""  # the namespace every drawn node shares, left out of the names
    compact: bool = False  # top-down, boxes, one line of details (COMPACT_FROM_CLUSTERS)


@dataclass(frozen=True, slots=True)
class Marking:
    """What decides how a component looks beyond its class: observers, analysis, health."""

    watched: Mapping[str, list[Watch]]
    undetected: Mapping[str, tuple[str, ...]]
    health: Marks | None
    focus: str | None
