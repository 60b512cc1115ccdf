"""The summary: one box per namespace, arrows counting the topics between them."""

from __future__ import annotations

from collections.abc import Mapping

from rac.ir import Model, Node
from rac.targets.coverage import Marks
from rac.targets.diagram.layers import feedback, flow_order
from rac.targets.diagram.scene import (
    ARROW,
    COLOURS,
    EDGE_STYLE,
    STYLE,
    Item,
    Scene,
    arrow,
    place_labels,
)
from rac.targets.diagram.text import elide, html_text, quote, shown
from rac.targets.diagram.topology import Topology, common_namespace, short

# Above this many nodes, the default drawing is the summary: one box per namespace, each
# opened by --focus.  The node view of bench/diagram.py's synthetic robots fits 3,000 × 2,000
# pt up to about 60 nodes in one namespace and 30 in four; at 100 nodes it was 4,160 pt wide
# in one namespace and 7,213 pt in six, at 300 nodes 14,968 pt: pan and zoom, or a summary.
SUMMARY_ABOVE_NODES = 100
ONE_NAMESPACE_SUMMARY_ABOVE_NODES = 300
# The summary draws at most this many arrows per namespace box, the heaviest flows.
SUMMARY_ARROWS_PER_BOX = 2
GROUP_ID = "group:"  # a namespace box's id: ':' is in no ROS name


def summarised(model: Model) -> bool:
    """Whether the default drawing of ``model`` is the summary: above SUMMARY_ABOVE_NODES
    nodes in two namespaces or more; in one namespace (where its one box says little) only
    above ONE_NAMESPACE_SUMMARY_ABOVE_NODES, as before the node view: Graphviz takes long
    beyond (bench/diagram.py's robot of one namespace: 9 s at 300 nodes, 19 s at 1,000)."""
    if len(model.nodes) <= SUMMARY_ABOVE_NODES:
        return False
    return len(model.nodes) > ONE_NAMESPACE_SUMMARY_ABOVE_NODES or len(namespace_groups(model)) > 1


def draw_summary(
    model: Model, undetected: Mapping[str, tuple[str, ...]], health: Marks | None
) -> Scene:
    """One box per namespace: its nodes, hardware, topics and unseen faults; arrows between
    namespaces count the topics that cross."""
    scene = Scene()
    groups = namespace_groups(model)
    owner = {n.name.value: g for g, members in groups.items() for n in members}
    inside, crossing = flows(model, owner)
    for g, members in groups.items():
        scene.items.append(group_item(g, members, inside.get(g, 0), undetected, health, scene))
    scene.legend["group"] = None
    flow_edges(scene, crossing, len(groups))
    place_labels(scene)
    why = f" (over {SUMMARY_ABOVE_NODES} nodes)" if len(model.nodes) > SUMMARY_ABOVE_NODES else ""
    scene.notes.append(
        f"summary of {len(model.nodes):,} nodes in {len(groups):,} namespaces{why}; "
        "racc diagram MODEL --focus NAME or --all draws the detail"
    )
    relations = len(model.related) + len(model.intervals)
    if relations:
        scene.relations = [f"{relations:,} related pairs and intervals"]
    return scene


def namespace_groups(model: Model) -> dict[str, list[Node]]:
    """Nodes by the first namespace level below the one they all share."""
    prefix = common_namespace([n.name.value for n in model.nodes])
    groups: dict[str, list[Node]] = {}
    for node in model.nodes:
        name = node.name.value
        rest = short(name, prefix) if prefix else name.lstrip("/")
        head, sep, _ = rest.partition("/")
        group = (prefix + "/" + head if prefix else "/" + head) if sep else (prefix or "/")
        groups.setdefault(group, []).append(node)
    return groups


def flows(
    model: Model, owner: Mapping[str, str]
) -> tuple[dict[str, int], dict[tuple[str, str], int]]:
    """Topics per namespace, and topics from one namespace's publishers to another's readers."""
    crossing: dict[tuple[str, str], int] = {}
    inside: dict[str, int] = {}
    top = Topology(model)
    for name in top.names:
        # dicts, not sets: the arrows follow declaration order, the same in every run
        pubs = dict.fromkeys(owner[p] for p in top.publishers.get(name, ()) if p in owner)
        subs = dict.fromkeys(owner[s] for s in top.subscribers.get(name, []) if s in owner)
        for g in pubs or subs:
            inside[g] = inside.get(g, 0) + 1
        for a in pubs:
            for b in (s for s in subs if s != a):
                crossing[(a, b)] = crossing.get((a, b), 0) + 1
    return inside, crossing


def group_item(
    group: str,
    members: list[Node],
    topics: int,
    undetected: Mapping[str, tuple[str, ...]],
    health: Marks | None,
    scene: Scene,
) -> Item:
    hardware = sum(len(n.drives) for n in members)
    lines = [f"{len(members):,} nodes, {hardware:,} hardware", f"{topics:,} topics"]
    names = {n.name.value for n in members} | {h.value for n in members for h in n.drives}
    attrs = STYLE["group"]
    unseen = len(names & set(undetected))
    if unseen:
        lines.append(f"{unseen:,} with faults unseen")
        attrs += f', penwidth=2, color="{COLOURS["undetected"]}"'
        scene.legend["undetected"] = None
    hit = len(names & (health.faulty | health.suspect)) if health is not None else 0
    if hit:
        lines.append(f"{hit} diagnosed")
        attrs += f', fillcolor="{COLOURS["suspect"]}"'
        scene.legend["suspect"] = None
    lines.append(f"--focus {elide(group)} opens it")
    label = "<" + "<BR/>".join([f"<B>{shown(group)}</B>", *map(html_text, lines)]) + ">"
    tip = f"{group}: racc diagram MODEL --focus {group} draws its nodes"
    return Item(GROUP_ID + group, attrs, label, tip)


def flow_edges(scene: Scene, crossing: Mapping[tuple[str, str], int], boxes: int) -> None:
    """The heaviest flows only: every pair of 37 namespaces of a 1,000-node robot is 1,051
    arrows, which Graphviz takes minutes over and nobody can follow."""
    limit = SUMMARY_ARROWS_PER_BOX * boxes
    ranked = sorted(crossing.items(), key=lambda item: -item[1])  # stable: ties keep order
    drawn = dict(ranked[:limit])
    if len(ranked) > limit:
        least = ranked[limit - 1][1]
        scene.notes.append(
            f"{len(ranked) - limit:,} weaker flows between namespaces (≤ {least} topics) not drawn"
        )
    boxes_in_order = list(dict.fromkeys(g for pair in crossing for g in pair))
    order = flow_order(boxes_in_order, drawn)  # the namespaces by data flow, as the nodes
    back = feedback(order, drawn)
    for (a, b), n in crossing.items():
        if (a, b) not in drawn:
            continue
        text = f"{n:,} topics" if n != 1 else "1 topic"
        attrs = f"{EDGE_STYLE['group_flow']}, penwidth={min(1 + n / 20, 4):.1f}"
        tip = f"{a}{ARROW}{b}: {text}"
        named = (html_text(text), tip, f"{GROUP_ID}{a}{ARROW}{GROUP_ID}{b}")
        tail, head = GROUP_ID + a, GROUP_ID + b
        arrow(scene, tail, head, f"{attrs}, tooltip={quote(tip)}", (a, b) in back, named)
    if back:
        scene.legend["feedback"] = None


def draw_outside(
    model: Model, top: Topology, drawn: set[str], scene: Scene, visible: list[str]
) -> list[str]:
    """A namespace opened with ``--focus``: the namespaces around it as the summary's boxes,
    an arrow per box and drawn node, labelled with the topics between them.  Returns the
    topics still to draw: those that do not cross to a box."""
    groups = namespace_groups(model)
    owner = {n.name.value: g for g, members in groups.items() for n in members}
    outside = {n: g for n, g in owner.items() if n not in drawn}
    inflow: dict[tuple[str, str], list[str]] = {}  # (box, node) -> topics
    for name in top.names:
        pubs = top.publishers.get(name, ())
        subs = top.subscribers.get(name, [])
        for p in pubs:
            for s in subs:
                if p in outside and s in drawn:
                    inflow.setdefault((GROUP_ID + outside[p], s), []).append(name)
                elif p in drawn and s in outside:
                    inflow.setdefault((p, GROUP_ID + outside[s]), []).append(name)
    crossing = {t for topics in inflow.values() for t in topics}
    boxes = dict.fromkeys(end for pair in inflow for end in pair if end.startswith(GROUP_ID))
    inside, _ = flows(model, owner)
    for box in boxes:
        group = box[len(GROUP_ID) :]
        item = group_item(group, groups[group], inside.get(group, 0), {}, None, scene)
        scene.items.append(item)
    if boxes:
        scene.legend["group"] = None
    for (tail, head), topics in inflow.items():  # unlabelled: 25 labels in a row were a wall
        unique = list(dict.fromkeys(topics))
        tip = f"{tail.removeprefix(GROUP_ID)}{ARROW}{head.removeprefix(GROUP_ID)}: "
        tip += ", ".join(unique)
        width = f"penwidth={min(1 + len(unique) / 5, 3):.1f}"
        arrow(scene, tail, head, f"{EDGE_STYLE['group_flow']}, {width}, tooltip={quote(tip)}")
    return [t for t in visible if t not in crossing]
