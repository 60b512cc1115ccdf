"""The node-centric drawing: one arrow per ordered pair of nodes, laid out by data flow,
hubs drawn beside the nodes they talk to (docs/diagrams.md, "The node view").

- **One arrow per pair.** All the topics from one node to another share one arrow,
  labelled with the topic (one) or ``N topics: FIRST`` (several); FIRST is the one a
  reviewer most needs (an observer reads it bad, then a watched one, then declaration
  order), the tooltip lists them all.
- **A topic box only where the picture needs one:** a topic of several publishers (the
  box shows they feed one stream, which one observer watches); a watched topic that
  :data:`BOX_FROM_READERS` or more nodes read (its rate band written once, not on each
  arrow); a topic with no publisher or no reader drawn (it ends at the box).  An observed
  infrastructure topic (``/tf``, ``/diagnostics``…) is a box without arrows: it names how
  many nodes publish and read it, the tooltip which, since arrows would tie every node to
  every other one.
- **Layers** (:mod:`rac.targets.diagram.layers`): sources first, feedback arrows drawn
  against the layering.
- **Hubs.** A node tied to more than a third of the others (and to at least
  :data:`HUB_MIN_PARTNERS`) is drawn beside each node it talks to, instead of once with
  arrows that cross the whole page: the copies are dashed but one, which carries its
  details, and every copy carries its marks (diagnosis, unseen faults).  On the tugger
  (tests/tug/tugger.yaml) its arrows crossed others 138 times drawn once, 138 bundled by
  Graphviz's ``concentrate`` (bundles are as long, and an arrow through its label has no
  twin to merge with), 90 with one copy per layer, 61 with a copy per partner.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from rac.ir import Model
from rac.targets.coverage import TOPIC_ID, Marks, Watch, is_infrastructure
from rac.targets.diagram.layers import lay_out
from rac.targets.diagram.scene import ARROW, EDGE_STYLE, Item, Scene, arrow
from rac.targets.diagram.text import quote
from rac.targets.diagram.topics import TopicLook, topic_box, topic_looks
from rac.targets.diagram.topology import Topology, count_text

# A watched topic read by this many drawn nodes or more is a box: one label for its rate.
BOX_FROM_READERS = 3
# A hub is tied to more than a third of the other drawn nodes, and to at least this many.
HUB_SHARE = 3
HUB_MIN_PARTNERS = 6
HUB_COPY = "#"  # a hub's copy k is drawn as NAME#k: '#' is in no ROS name


@dataclass(slots=True)
class _Graph:
    """The drawn graph at node level: arrows between nodes and topic boxes."""

    pairs: dict[tuple[str, str], list[str]] = field(default_factory=dict)  # topics carried
    boxes: list[str] = field(default_factory=list)  # topics drawn as boxes with arrows
    alone: list[str] = field(default_factory=list)  # observed infrastructure: no arrows
    # arrows to and from boxes: (tail, head, topic), tails and heads as drawn ids
    box_edges: list[tuple[str, str, str]] = field(default_factory=list)


def draw_flow(
    model: Model,
    top: Topology,
    visible: list[str],
    shown: set[str],
    scene: Scene,
    watched: Mapping[str, list[Watch]],
    health: Marks | None,
    prefix: str,
) -> None:
    """Topic boxes, hub copies and the arrows of the node view, and the layering."""
    looks = topic_looks(top, visible, scene, watched, health, prefix)
    graph = _classify(top, visible, shown, watched)
    owners = {item.id: item.cluster for item in scene.items}
    for name in graph.boxes:
        pubs = [p for p in top.publishers.get(name, ()) if p in shown]
        subs = [s for s in top.subscribers.get(name, []) if s in shown]
        topic_box(name, looks[name], top, scene, owners.get((pubs or subs or [""])[0], ""))
    for name in graph.alone:
        pubs = [p for p in top.publishers.get(name, ()) if p in shown]
        subs = [s for s in top.subscribers.get(name, []) if s in shown]
        counts = f"{count_text(len(pubs), 'publisher')} · {count_text(len(subs), 'reader')}"
        look = looks[name]
        tip = f"{look.tip}\npublished by {', '.join(pubs) or 'no node drawn'}\n"
        tip += f"read by {', '.join(subs) or 'no node drawn'}"
        extra = f'<BR/><FONT POINT-SIZE="8">{counts}</FONT>'
        topic_box(name, TopicLook(look.line, tip, look.weight), top, scene, "", extra)
        scene.legend["alone"] = None

    nodes = [n.name.value for n in model.nodes if n.name.value in shown]
    ties = _partners(graph, nodes)
    hubs = [
        n
        for n in nodes
        if len(ties[n]) * HUB_SHARE > len(nodes) - 1 and len(ties[n]) >= HUB_MIN_PARTNERS
    ]
    all_edges = [*graph.pairs, *((a, b) for a, b, _ in graph.box_edges)]
    layout = lay_out(model, nodes, [TOPIC_ID + t for t in graph.boxes], all_edges, hubs)
    back = layout.back
    copies = _hub_copies(hubs, graph)
    for hub, numbered in copies.items():
        _draw_copies(hub, numbered, scene)
    scene.sources = layout.sources

    def end(name: str, other: str) -> str:
        """The drawn id of ``name`` at an arrow to or from ``other`` (a hub: its copy)."""
        if name in copies:
            return f"{name}{HUB_COPY}{copies[name][other]}" if other in copies[name] else name
        return name

    for (pub, sub), carried in graph.pairs.items():
        ordered = sorted(carried, key=lambda t: looks[t].weight)  # stable: declaration order
        first = looks[ordered[0]]
        label = first.line if len(carried) == 1 else f"{len(carried)} topics: {first.line}"
        tip = f"{pub}{ARROW}{sub}: " + "; ".join(looks[t].tip for t in ordered)
        named = (label, tip, f"{pub}{ARROW}{sub}")
        tail, head = end(pub, sub), end(sub, pub)
        arrow(scene, tail, head, f"tooltip={quote(tip)}", (pub, sub) in back, named)
        scene.legend["pair"] = None
    for tail, head, name in graph.box_edges:
        look = looks[name]
        if tail.startswith(TOPIC_ID):
            attrs = f"tooltip={quote(f'{head} subscribes {look.tip}')}"
        else:
            attrs = f"{EDGE_STYLE['publish']}, tooltip={quote(f'{tail} publishes {look.tip}')}"
        arrow(scene, end(tail, head), end(head, tail), attrs, (tail, head) in back)
    if back:
        scene.legend["feedback"] = None


def _classify(
    top: Topology, visible: list[str], shown: set[str], watched: Mapping[str, list[Watch]]
) -> _Graph:
    graph = _Graph()
    for name in visible:
        pubs = [p for p in top.publishers.get(name, ()) if p in shown]
        subs = [s for s in top.subscribers.get(name, []) if s in shown]
        if is_infrastructure(name):
            graph.alone.append(name)
            continue
        box = len(pubs) > 1 or not pubs or not subs
        box = box or (len(subs) >= BOX_FROM_READERS and bool(watched.get(TOPIC_ID + name)))
        if box:
            graph.boxes.append(name)
            key = TOPIC_ID + name
            graph.box_edges += [(p, key, name) for p in pubs]
            graph.box_edges += [(key, s, name) for s in subs]
            continue
        for pub in pubs:
            for sub in subs:
                if pub != sub:
                    graph.pairs.setdefault((pub, sub), []).append(name)
    return graph


def _partners(graph: _Graph, nodes: list[str]) -> dict[str, set[str]]:
    """Per node, the other nodes it sends to or reads from, through an arrow or a box."""
    ties: dict[str, set[str]] = {n: set() for n in nodes}
    for a, b in graph.pairs:
        ties[a].add(b)
        ties[b].add(a)
    through: dict[str, tuple[set[str], set[str]]] = {}
    for tail, head, name in graph.box_edges:
        pubs, subs = through.setdefault(name, (set(), set()))
        (pubs.add(tail) if head.startswith(TOPIC_ID) else subs.add(head))
    for pubs, subs in through.values():
        for p in pubs:
            ties[p] |= subs - {p}
        for s in subs:
            ties[s] |= pubs - {s}
    return ties


def _hub_copies(hubs: list[str], graph: _Graph) -> dict[str, dict[str, int]]:
    """Per hub, per neighbour it has an arrow with, the number of the copy drawn beside it.

    Each neighbour (node or topic box) has a copy of its own, numbered from 1 in the order
    of the arrows: Graphviz then places it next to that neighbour.  Copies shared by the
    neighbours of one layer (tried first) still drew long arrows across a top-down page, as
    a layer spans its width (the tugger: 90 crossings, 61 with a copy each).  The arrows
    between two hubs join copies of their own, numbered 0, which stand together.
    """
    numbered: dict[str, dict[str, int]] = {h: {} for h in hubs}
    ends = [(a, b) for a, b in graph.pairs] + [(a, b) for a, b, _ in graph.box_edges]
    for a, b in ends:
        if a in numbered and b in numbered:
            numbered[a][b] = numbered[b][a] = 0
        elif a in numbered:
            numbered[a].setdefault(b, len(numbered[a]) + 1)
        elif b in numbered:
            numbered[b].setdefault(a, len(numbered[b]) + 1)
    return numbered


def main_copy(numbered: Mapping[str, int]) -> int:
    """The copy with the most arrows to nodes that are no hubs (the first of those): it
    carries the hub's details."""
    arrows: dict[int, int] = {}
    for k in numbered.values():
        arrows[k] = arrows.get(k, 0) + (k != 0)
    return max(sorted(arrows), key=lambda k: arrows[k], default=1)


def _draw_copies(hub: str, numbered: Mapping[str, int], scene: Scene) -> None:
    """The hub's item becomes its copies, one per number: the one with the most arrows
    carries the details, the others are dashed and carry the name."""
    if not numbered:
        return
    index = next(i for i, item in enumerate(scene.items) if item.id == hub)
    item = scene.items[index]
    scene.legend["hub"] = None
    numbers = sorted(set(numbered.values()))
    main = main_copy(numbered)
    note = f"\ndrawn {len(numbers)} times, beside the nodes it talks to (a hub)"
    copies = []
    for k in numbers:
        attrs = item.attrs if k == main else _dashed(item.attrs)
        label = item.label if k == main else quote(item.shown)
        copies.append(Item(f"{hub}{HUB_COPY}{k}", attrs, label, item.tooltip + note, ""))
    scene.items[index : index + 1] = copies


def _dashed(attrs: str) -> str:
    if 'style="' in attrs:
        head, _, rest = attrs.partition('style="')
        style, _, tail = rest.partition('"')
        return f'{head}style="{style},dashed"{tail}'
    return attrs + ', style="rounded,filled,dashed"'
