"""What one drawing holds before it is written as DOT: the view asked for, the items and
arrows, the legend keys used and the caption's notes; the styles of each kind of item."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from rac.targets.coverage import Health, Marks, Watch
from rac.targets.diagram.text import bounded, quote

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
    # node-to-node hops around the focus, upstream and downstream; None: 1 around a node,
    # hardware or topic, 0 around a namespace (its neighbours are drawn as namespace boxes)
    depth: int | None = None
    summary: bool = False  # one box per namespace
    # "nodes": one arrow per pair of nodes (the node view), "topics": every topic drawn on
    # its arrows, "auto": the node view above NODE_VIEW_ABOVE_NODES drawn nodes
    level: str = "auto"
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
    shown: str = ""  # the name as drawn (a hub's copies repeat it)
    ends: tuple[str, str] | None = None  # an arrow's label: the arrow's tail and head


@dataclass(slots=True)
class Scene:
    """Everything one drawing holds, before it is written as DOT."""

    items: list[Item] = field(default_factory=list)
    edges: list[str] = field(default_factory=list)  # finished edge statements
    legend: dict[str, None] = field(default_factory=dict)  # legend keys used, in order
    notes: list[str] = field(default_factory=list)  # caption lines (plain text)
    relations: list[str] = field(default_factory=list)  # the related pairs, as written
    prefix: str = ""  # the namespace every drawn node shares, left out of the names
    compact: bool = False  # boxes, one line of details (COMPACT_FROM_CLUSTERS, node view)
    rankdir: str = "LR"  # the direction of data flow: left to right, or top to bottom (TB)
    sources: list[str] = field(default_factory=list)  # drawn ids on the first layer
    drawn: int = 0  # the model's nodes drawn
    by_nodes: bool = False  # the node view (rac.targets.diagram.flow)
    clusters: bool = True  # namespaces drawn as clusters (not in the node view)


@dataclass(frozen=True, slots=True)
class Marking:
    """What decides how a component looks beyond its class: observers, analysis, health."""

    watched: Mapping[str, list[Watch]]
    undetected: Mapping[str, tuple[str, ...]]
    health: Marks | None
    focus: str | None


LABEL_STYLE = 'shape=plaintext, margin="0.03,0.01", width=0, height=0, fontsize=9'
ARROW = " → "  # a labelled arrow's label is the node "TAIL → HEAD": '→' is in no ROS name


def arrow(
    scene: Scene,
    tail: str,
    head: str,
    attrs: str,
    backwards: bool = False,
    label: tuple[str, str, str] | None = None,
) -> None:
    """An arrow from drawn id ``tail`` to ``head``.

    A feedback arrow (``backwards``) is written head to tail, so that Graphviz ranks it with
    the flow, and drawn reversed.  A labelled arrow (``label``: its HTML, tooltip and the
    name of the arrow) is two edges through a node that is the label: Graphviz routes other
    arrows around a node, but lets them cross an edge's own label (issue 37: ``/scan @ 10
    Hz`` sat on the ekf → controller arrow).  The label stands on its arrow, in the
    namespace of both ends if they share one.
    """
    if label is None:
        if backwards:
            scene.edges.append(f"  {quote(head)} -> {quote(tail)} [dir=back, {attrs}];\n")
        else:
            scene.edges.append(f"  {quote(tail)} -> {quote(head)} [{attrs}];\n")
        return
    html, tip, name = label
    name = ARROW.join(bounded(end) for end in name.split(ARROW, 1))
    scene.items.append(Item(name, LABEL_STYLE, f"<{html}>", tip, ends=(tail, head)))
    via = quote(name)
    if backwards:
        scene.edges.append(f"  {quote(head)} -> {via} [dir=back, {attrs}];\n")
        scene.edges.append(f"  {via} -> {quote(tail)} [dir=none, {attrs}];\n")
    else:
        scene.edges.append(f"  {quote(tail)} -> {via} [dir=none, {attrs}];\n")
        scene.edges.append(f"  {via} -> {quote(head)} [{attrs}];\n")


def place_labels(scene: Scene) -> None:
    """Each arrow's label in the namespace cluster both its ends share, else outside."""
    owner = {item.id: item.cluster for item in scene.items}
    for item in scene.items:
        if item.ends is not None:
            tail, head = (owner.get(end, "") for end in item.ends)
            item.cluster = tail if tail == head else ""
