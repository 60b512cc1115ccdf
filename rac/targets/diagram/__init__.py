"""The architecture drawn for a reviewer (docs/diagrams.md), with Figure 3.1's conventions.

Hardware are rectangles, nodes ellipses or rounded boxes filled by class (SN dark grey, HN
grey, N white), publish/subscribe arrows carry their topics, dotted lines join a driver to
its hardware.  Three views of one model:

- the topic view (:mod:`.topics`; up to NODE_VIEW_ABOVE_NODES drawn nodes, ``--topics``,
  ``--all``): every drawn topic on its arrow or in its box, nodes clustered by namespace;
- the node view (:mod:`.flow`; above that): one arrow per ordered pair of nodes, topic boxes
  only where needed, hubs beside the nodes they talk to, no cluster;
- the summary (:mod:`.summary`; above SUMMARY_ABOVE_NODES nodes in several namespaces): one
  box per namespace; ``--focus NAMESPACE`` opens one, the others as boxes around it.

Both detailed views are laid out by data flow (:mod:`.layers`), fold the topics at most one
node touches and no observer watches, and the unobserved infrastructure topics, into a count
on their node, show what watches each node and topic, and outline in red a component whose
fault no observer detects (:attr:`View.undetected`); :attr:`View.focus` draws a
neighbourhood, :attr:`View.health` colours a diagnosis; the legend lists only the symbols
drawn.  Every string is quoted or escaped by :mod:`.text`, safe for Graphviz whatever the
model holds; the template holds the fixed text.  Everything follows declaration order: the
output is byte-identical from run to run.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from rac.ir import Model
from rac.passes.observers import ObserverSpec
from rac.targets.coverage import Marks, Watch, component_keys, marks, watches
from rac.targets.diagram.components import draw_components
from rac.targets.diagram.flow import draw_flow
from rac.targets.diagram.layers import first_layer
from rac.targets.diagram.scene import Item, Marking, Scene, View, place_labels
from rac.targets.diagram.summary import (
    SUMMARY_ABOVE_NODES,
    draw_outside,
    draw_summary,
    summarised,
)
from rac.targets.diagram.text import html_text, quote
from rac.targets.diagram.topics import MAX_RELATIONS_SHOWN, draw_topics, fold, relation_list
from rac.targets.diagram.topology import (
    Topology,
    cluster_of,
    common_namespace,
    focus_namespace,
    focus_set,
)
from rac.targets.diagram.write import write_scene

__all__ = [
    "MAX_RELATIONS_SHOWN",
    "NODE_VIEW_ABOVE_NODES",
    "SUMMARY_ABOVE_NODES",
    "Drawing",
    "View",
    "draw_diagram",
    "emit_diagram",
    "html_text",
    "quote",
    "summarised",
]

# A drawing of two or more namespaces is compact (docs/diagrams.md, "Reading it at
# 1920 × 1080"): top-down, so an arrow's label sits beside it instead of taking a column of
# its own; nodes are rounded boxes with one line of details, since an ellipse around several
# lines is twice as wide.  The 31-node warehouse robot went from 2734 × 1324 pt to about
# 1470 × 1090 pt, its names readable on a 1920 × 1080 screen.
COMPACT_FROM_CLUSTERS = 2
# Above this many drawn nodes the default is the node view (rac.targets.diagram.flow).
NODE_VIEW_ABOVE_NODES = 12


@dataclass(frozen=True, slots=True)
class Drawing:
    """A drawing's DOT text and what it shows."""

    text: str
    nodes: int  # the model's nodes drawn (a summary: all of them, in its boxes)
    view: str  # "topics", "nodes" or "summary"


def emit_diagram(model: Model, observers: Iterable[ObserverSpec], view: View) -> str:
    """The DOT text of ``view`` of ``model``; pure."""
    return draw_diagram(model, observers, view).text


def draw_diagram(model: Model, observers: Iterable[ObserverSpec], view: View) -> Drawing:
    """``view`` of ``model`` (docs/diagrams.md); pure."""
    summary = view.summary and not view.everything and view.focus is None
    # The summary shows no single observer: it need not turn 39,000 of them around.
    watched = {} if summary and view.health is None else watches(model, observers)
    health = marks(model, watched, view.health) if view.health is not None else None
    keys = component_keys(model)
    undetected: dict[str, tuple[str, ...]] = {}
    for component, modes in view.undetected or ():
        undetected[keys.get(component, component)] = modes
    if summary:
        scene, clusters = draw_summary(model, undetected, health), dict[str, list[Item]]()
        drawn, kind = len(model.nodes), "summary"
    else:
        scene, clusters = detailed(model, view, watched, undetected, health)
        drawn, kind = scene.drawn, ("nodes" if scene.by_nodes else "topics")
    if view.undetected is None:
        scene.notes.append("faults no observer detects: not analysed (racc diagram marks them)")
    if view.health is not None:
        scene.notes.insert(0, view.health.title)
    text = write_scene(model, scene, clusters, view.summary and not view.everything)
    return Drawing(text, drawn, kind)


def detailed(
    model: Model,
    view: View,
    watched: Mapping[str, list[Watch]],
    undetected: Mapping[str, tuple[str, ...]],
    health: Marks | None,
) -> tuple[Scene, dict[str, list[Item]]]:
    top = Topology(model)
    scene = Scene()
    drawn: set[str] | None = None
    space: str | None = None
    if view.focus is not None:
        space = focus_namespace(model, top, view.focus)
        depth = view.depth if view.depth is not None else (0 if space else 1)
        drawn = focus_set(model, top, view.focus, depth)
        if drawn is None:
            raise ValueError(f"no node, hardware, topic or namespace named {view.focus!r}")
        what = f"namespace {space}" if space else view.focus
        scene.notes.append(f"focus: {what}, {depth} hop(s) up- and downstream")
    nodes = [n for n in model.nodes if drawn is None or n.name.value in drawn]
    shown = {n.name.value for n in nodes}
    prefix = scene.prefix = common_namespace([n.name.value for n in nodes])
    if prefix:
        scene.notes.append(f"names under {prefix}/ are drawn without it")
    spaces = {cluster_of(n.name.value, prefix) for n in nodes}
    by_nodes = view.level == "nodes" or (
        view.level == "auto" and not view.everything and len(nodes) > NODE_VIEW_ABOVE_NODES
    )
    scene.drawn, scene.by_nodes = len(nodes), by_nodes
    # The node view draws no namespace cluster (its names keep their namespace below the
    # shared one): around clusters, Graphviz routed arrows through nodes and labels and
    # crossed them more (bench/diagram.py: the warehouse 37 crossings with clusters, 25
    # without; a 100-node robot in 6 namespaces 1,454 and 282).
    scene.clusters = not by_nodes
    clustered = scene.clusters and len(spaces - {""}) >= COMPACT_FROM_CLUSTERS
    scene.compact = not view.everything and (clustered or by_nodes)
    # Compact drawings go top-down (see COMPACT_FROM_CLUSTERS): the tugger of
    # tests/tug/tugger.yaml by nodes was 2603 × 1008 pt left to right, 1905 × 901 top-down.
    scene.rankdir = "TB" if scene.compact else "LR"

    visible, folded = fold(top, shown, drawn is not None, watched, view.everything, scene)
    marking = Marking(watched, undetected, health, view.focus)
    draw_components(model, nodes, scene, marking, folded)
    if space is not None:  # the namespaces around it as the summary's boxes
        visible = draw_outside(model, top, shown, scene, visible)
    if by_nodes:
        draw_flow(model, top, visible, shown, scene, watched, health, prefix)
    else:
        draw_topics(model, top, visible, shown, scene, watched, health, prefix)
    relation_list(model, scene)
    place_labels(scene)
    if clustered:  # each namespace stays together: a first layer across them stretched
        scene.sources = []  # the drivers' cluster down the page (bench/diagram.py)
    scene.sources = first_layer(model, scene.sources, (item.id for item in scene.items))
    clusters: dict[str, list[Item]] = {}
    for item in scene.items:
        clusters.setdefault(item.cluster, []).append(item)
    if len(clusters) > 1 or "" not in clusters:
        scene.legend["namespace"] = None
    return scene, clusters
