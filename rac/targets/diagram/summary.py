"""The summary: one box per namespace, arrows counting the topics between them."""

from __future__ import annotations

from collections.abc import Mapping

from rac.ir import Model, Node
from rac.targets.coverage import Marks
from rac.targets.diagram.scene import COLOURS, EDGE_STYLE, STYLE, Item, Scene
from rac.targets.diagram.text import html_text, quote
from rac.targets.diagram.topology import Topology, common_namespace, short

# Above this many nodes, architecture.dot is the summary: one box per namespace (a full
# drawing of 10,000 nodes took Graphviz 24 s and 10 MB of SVG that nobody can read).
SUMMARY_ABOVE_NODES = 300
# The summary draws at most this many arrows per namespace box, the heaviest flows.
SUMMARY_ARROWS_PER_BOX = 2


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
    label = "<" + "<BR/>".join([f"<B>{html_text(group)}</B>", *map(html_text, lines)]) + ">"
    return Item("group:" + group, attrs, label, group)


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
    for (a, b), n in crossing.items():
        if (a, b) not in drawn:
            continue
        scene.edges.append(
            f"  {quote('group:' + a)} -> {quote('group:' + b)} [{EDGE_STYLE['group_flow']}, "
            f"label={quote(f'{n:,} topics' if n != 1 else '1 topic')}, penwidth="
            f"{min(1 + n / 20, 4):.1f}, tooltip={quote(f'{a} → {b}: {n} topics')}];\n"
        )
