"""architecture.dot: the Graphviz diagram, drawn with Figure 3.1's conventions.

Hardware are rectangles, nodes ellipses filled by class (SN dark grey, HN grey, N white),
publish/subscribe arrows carry their topics, dotted lines join a driver to its hardware.
On top of the dissertation's figure, for a reviewer (docs/diagrams.md):

- nodes are clustered by namespace;
- a topic only one node touches and that no observer watches, and the infrastructure
  topics (/rosout, /tf, …) unless observed, are folded into a count on their node
  ("+87 topics"); :attr:`View.everything` draws them all;
- what watches each node and topic is shown: the rate of a topic (its GObs), a node's cpu/mem
  limits and reports, ``~`` for a related pair; an unwatched topic is grey, a component whose
  fault no observer detects (``racc analyze``'s verdict, passed in :attr:`View.undetected`)
  is outlined red and dashed;
- :attr:`View.focus` draws one component's neighbourhood, :attr:`View.health` colours a
  diagnosis, and :attr:`View.summary` draws one box per namespace for a large model;
- the legend lists only the symbols the drawing uses.

This module decides *what* is drawn; every string is quoted or escaped here, the template
holds the fixed text.  Everything follows declaration order: the output is byte-identical
from run to run.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from rac.fmt import format_limits, format_mem, format_number
from rac.ir import Model, Node, Topic
from rac.passes.observers import ObserverSpec
from rac.pipeline import Compiled
from rac.targets.coverage import (
    TOPIC_ID,
    Health,
    Marks,
    Watch,
    component_keys,
    is_infrastructure,
    marks,
    watches,
)
from rac.targets.options import EmitOptions
from rac.targets.templating import render

# A topic with more publisher/subscriber pairs than this becomes a node of its own: one
# label and n+m arrows instead of n*m arrows each repeating the label.
MAX_WIRE_PAIRS = 2
# An arrow lists this many topics; the rest are counted ("+12 more") and in its tooltip.
MAX_LABEL_LINES = 4
# The caption lists this many related pairs; the rest are counted.
MAX_RELATIONS_SHOWN = 24
RELATIONS_PER_COLUMN = 6
# Above this many nodes, architecture.dot is the summary: one box per namespace (a full
# drawing of 10,000 nodes took Graphviz 24 s and 10 MB of SVG that nobody can read).
SUMMARY_ABOVE_NODES = 300
# dot's classic ranking of many clusters fails ("trouble in init_rank": a 300-node robot in
# 37 namespaces) or takes long; newrank does not, at the price of a wider drawing of a few.
NEWRANK_ABOVE_CLUSTERS = 12
# A drawing of two or more namespaces is compact (docs/diagrams.md, "Reading it at
# 1920 × 1080"): top-down, so an arrow's label sits beside it instead of taking a column of
# its own; nodes are rounded boxes with one line of details, since an ellipse around several
# lines is twice as wide.  The 31-node warehouse robot went from 2734 × 1324 pt to about
# 1470 × 1090 pt, its names readable on a 1920 × 1080 screen.
COMPACT_FROM_CLUSTERS = 2
# The summary draws at most this many arrows per namespace box, the heaviest flows.
SUMMARY_ARROWS_PER_BOX = 2

NAME_GAP = '<BR/><FONT POINT-SIZE="3"> </FONT><BR/>'

_DOT_SPECIAL = re.compile(r'[\\"\r\n]')

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


def quote(text: str) -> str:
    """A DOT double-quoted string whose escString value is ``text`` verbatim.

    Backslashes are doubled so Graphviz's label escapes (``\\N``, ``\\G``, ``\\l``…) cannot
    fire by accident; a line break becomes DOT's ``\\n``.
    """
    if _DOT_SPECIAL.search(text) is None:
        return f'"{text}"'  # the usual name: nothing to escape
    body = text.replace("\\", "\\\\").replace('"', '\\"')
    return '"' + body.replace("\r\n", "\n").replace("\r", "\n").replace("\n", "\\n") + '"'


def html_text(text: str) -> str:
    """Text for a Graphviz HTML-like label (XML; a line break is ``<BR/>``)."""
    # xml.sax.saxutils.escape's replacements, without its import (urllib: 30 ms of start-up).
    escaped = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return escaped.replace('"', "&quot;").replace("\n", '<BR ALIGN="LEFT"/>')


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


def node_class(node: Node, switchable: set[str], hardware: set[str]) -> str:
    """SN drives switchable hardware, HN only other hardware, N none (docs/spec.md)."""
    drives = {h.value for h in node.drives}
    if drives & switchable:
        return "sn"
    if drives & hardware:
        return "hn"
    return "n"


def namespace(name: str) -> str:
    """``/robot_41/nav/planner`` -> ``/robot_41/nav``; a global or bare name -> ``""``."""
    head, sep, _ = name.rpartition("/")
    return head if sep and head else ""


def _rate(topic: Topic | None) -> str:
    if topic is None or topic.rate_hz is None:
        return ""
    return f"{format_number(topic.rate_hz)} Hz"


@dataclass(slots=True)
class _Item:
    """A node statement: raw id, attributes, label (already DOT: quoted or <HTML>), tooltip."""

    id: str
    attrs: str
    label: str
    tooltip: str
    cluster: str = ""


@dataclass(slots=True)
class _Scene:
    """Everything one drawing holds, before it is written as DOT."""

    items: list[_Item] = field(default_factory=list)
    edges: list[str] = field(default_factory=list)  # finished edge statements
    legend: dict[str, None] = field(default_factory=dict)  # legend keys used, in order
    notes: list[str] = field(default_factory=list)  # caption lines (plain text)
    relations: list[str] = field(default_factory=list)  # the related pairs, as written
    prefix: str = ""  # the namespace every drawn node shares, left out of the names
    compact: bool = False  # top-down, boxes, one line of details (COMPACT_FROM_CLUSTERS)


class _Topology:
    """Who publishes and who reads each topic, and the topics' names in declaration order."""

    def __init__(self, model: Model) -> None:
        self.topics = model.topic_by_name()
        self.publishers = model.publishers()
        self.subscribers: dict[str, list[str]] = {}
        for node in model.nodes:
            for ref in node.subscribes:
                self.subscribers.setdefault(ref.value, []).append(node.name.value)
        names = list(self.topics)
        named = set(self.subscribers) | set(self.publishers)
        if not named.issubset(self.topics):  # only an unvalidated model names undeclared ones
            for node in model.nodes:
                for ref in [*node.subscribes, *(p.topic for p in node.publishes)]:
                    if ref.value not in self.topics and ref.value not in names:
                        names.append(ref.value)
        self.names = names

    def touching(self, topic: str) -> list[str]:
        return list(
            dict.fromkeys([*self.publishers.get(topic, ()), *self.subscribers.get(topic, [])])
        )


def _focus_set(model: Model, top: _Topology, focus: str, depth: int) -> set[str] | None:
    """The nodes within ``depth`` hops upstream or downstream of ``focus``; None: unknown."""
    by_node = model.node_by_name()
    drivers = {h.value: n.name.value for n in model.nodes for h in n.drives}
    if focus in by_node:
        start = {focus}
    elif focus in drivers:
        start = {drivers[focus]}
    elif focus in top.publishers or focus in top.subscribers or focus in top.topics:
        ends = [*top.publishers.get(focus, ()), *top.subscribers.get(focus, [])]
        start, depth = set(ends), max(depth - 1, 0)
    else:
        return None
    reads = {n.name.value: [r.value for r in n.subscribes] for n in model.nodes}
    writes = {n.name.value: list(n.published_topics) for n in model.nodes}
    keep = set(start)
    for step_in, step_out in ((reads, top.publishers), (writes, top.subscribers)):
        frontier = set(start)
        for _ in range(depth):
            nxt = {m for n in frontier for t in step_in[n] for m in step_out.get(t, ())}
            frontier = nxt - keep
            keep |= nxt
    return keep


def emit_dot(compiled: Compiled, options: EmitOptions) -> str:
    """architecture.dot: the reviewer's view, or the summary above SUMMARY_ABOVE_NODES nodes."""
    summary = len(compiled.model.nodes) > SUMMARY_ABOVE_NODES
    view = View(summary=summary, undetected=options.undetected)
    return emit_diagram(compiled.model, compiled.observers, view)


def emit_diagram(model: Model, observers: Iterable[ObserverSpec], view: View) -> str:
    """The DOT text of ``view`` of ``model``; pure."""
    summary = view.summary and not view.everything and view.focus is None
    # The summary shows no single observer: it need not turn 39,000 of them around.
    watched = {} if summary and view.health is None else watches(model, observers)
    health = marks(model, watched, view.health) if view.health is not None else None
    keys = component_keys(model)
    undetected: dict[str, tuple[str, ...]] = {}
    for component, modes in view.undetected or ():
        undetected[keys.get(component, component)] = modes
    if summary:
        scene, clusters = _summary(model, undetected, health), dict[str, list[_Item]]()
    else:
        scene, clusters = _detailed(model, view, watched, undetected, health)
    if view.undetected is None and not view.summary:
        scene.notes.append("faults no observer detects: not analysed (racc diagram marks them)")
    if view.health is not None:
        scene.notes.insert(0, view.health.title)
    return _write(model, scene, clusters, view.summary and not view.everything)


def _detailed(
    model: Model,
    view: View,
    watched: Mapping[str, list[Watch]],
    undetected: Mapping[str, tuple[str, ...]],
    health: Marks | None,
) -> tuple[_Scene, dict[str, list[_Item]]]:
    top = _Topology(model)
    scene = _Scene()
    drawn: set[str] | None = None
    if view.focus is not None:
        drawn = _focus_set(model, top, view.focus, view.depth)
        if drawn is None:
            raise ValueError(f"no node, hardware or topic named {view.focus!r}")
        scene.notes.append(f"focus: {view.focus}, {view.depth} hop(s) up- and downstream")
    nodes = [n for n in model.nodes if drawn is None or n.name.value in drawn]
    shown = {n.name.value for n in nodes}
    prefix = scene.prefix = _common_namespace([n.name.value for n in nodes])
    if prefix:
        scene.notes.append(f"names under {prefix}/ are drawn without it")
    spaces = {_cluster_of(n.name.value, prefix) for n in nodes}
    scene.compact = not view.everything and len(spaces - {""}) >= COMPACT_FROM_CLUSTERS

    visible, folded = _fold(top, shown, drawn is not None, watched, view.everything, scene)
    marking = _Marking(watched, undetected, health, view.focus)
    _draw_components(model, nodes, scene, marking, folded)
    _draw_topics(top, visible, shown, scene, watched, health, prefix)
    _relations(model, scene)
    clusters: dict[str, list[_Item]] = {}
    for item in scene.items:
        clusters.setdefault(item.cluster, []).append(item)
    if len(clusters) > 1 or "" not in clusters:
        scene.legend["namespace"] = None
    return scene, clusters


def _fold(
    top: _Topology,
    shown: set[str],
    focused: bool,
    watched: Mapping[str, list[Watch]],
    everything: bool,
    scene: _Scene,
) -> tuple[list[str], dict[str, int]]:
    """The topics to draw, and per node how many of its topics are folded into its count.

    Folded: a topic that at most one node touches and no observer watches, and an unobserved
    infrastructure topic.  A focused view leaves out the topics of nodes outside it.
    """
    folded: dict[str, int] = {}
    infrastructure: list[str] = []
    single = 0
    visible: list[str] = []
    for name in top.names:
        touching = top.touching(name)
        if not any(n in shown for n in touching) and (focused or touching):
            continue  # outside the focus (an unused topic is folded below)
        fold = not everything and TOPIC_ID + name not in watched
        if fold and (len(touching) <= 1 or is_infrastructure(name)):
            if is_infrastructure(name):
                infrastructure.append(name)
            else:
                single += 1
            for n in touching:
                folded[n] = folded.get(n, 0) + 1
            continue
        visible.append(name)
    if single:
        scene.notes.append(
            f"folded: {single} topic(s) that at most one node touches and no observer "
            "watches (counted on the node)"
        )
    if infrastructure:
        listed = ", ".join(_short(t, scene.prefix) for t in infrastructure[:6])
        more = f" and {len(infrastructure) - 6} more" if len(infrastructure) > 6 else ""
        scene.notes.append(f"folded: unobserved infrastructure topics {listed}{more}")
    if single or infrastructure:
        scene.legend["folded"] = None
        scene.notes.append("--all draws every topic")
    return visible, folded


def _common_namespace(names: list[str]) -> str:
    spaces = {namespace(n) for n in names}
    if not names or "" in spaces:
        return ""
    parts = [s.split("/") for s in spaces]
    common: list[str] = []
    for segment in zip(*parts, strict=False):
        if len(set(segment)) != 1:
            break
        common.append(segment[0])
    return "/".join(common)


def _short(name: str, prefix: str) -> str:
    return name[len(prefix) + 1 :] if prefix and name.startswith(prefix + "/") else name


def _cluster_of(name: str, prefix: str) -> str:
    space = namespace(name)
    return "" if space == prefix else space


@dataclass(frozen=True, slots=True)
class _Marking:
    """What decides how a component looks beyond its class: observers, analysis, health."""

    watched: Mapping[str, list[Watch]]
    undetected: Mapping[str, tuple[str, ...]]
    health: Marks | None
    focus: str | None


def _draw_components(
    model: Model,
    nodes: list[Node],
    scene: _Scene,
    marking: _Marking,
    folded: Mapping[str, int],
) -> None:
    switchable = {h.name.value for h in model.hardware if h.switchable}
    hardware = model.hardware_by_name()
    driven: dict[str, str] = {}  # device -> its driver's cluster
    first = len(scene.items)  # hardware goes before the nodes: above its driver
    for node in nodes:
        kind = node_class(node, switchable, set(hardware)) if node.drives else "n"
        name = node.name.value
        cluster = _cluster_of(name, scene.prefix)
        scene.items.append(_node_item(node, kind, cluster, scene, marking, folded.get(name, 0)))
        for h in node.drives:
            if h.value in hardware and h.value not in driven:
                driven[h.value] = cluster  # a device is drawn in its driver's namespace
                scene.edges.append(
                    f"  {quote(h.value)} -> {quote(name)} [{EDGE_STYLE['hardware_link']}, "
                    f"tooltip={quote(f'{name} drives {h.value}')}];\n"
                )
                scene.legend["hardware_link"] = None
    for hw in model.hardware:
        name = hw.name.value
        if name not in driven and marking.focus is not None and name != marking.focus:
            continue
        scene.legend["switchable" if hw.switchable else "hardware"] = None
        tip = [
            f"{name}: switchable, board channel {hw.channel}"
            if hw.switchable
            else f"{name}: hardware"
        ]
        tip += _watch_lines(marking.watched.get(name, []))
        attrs, warn = _marked(name, STYLE["hardware"], marking, scene, tip)
        label = _label(name, [f"ch {hw.channel}"] if hw.switchable else [], warn, dark=False)
        scene.items.insert(first, _Item(name, attrs, label, "\n".join(tip), driven.get(name, "")))
        first += 1


def _node_item(
    node: Node, kind: str, cluster: str, scene: _Scene, marking: _Marking, folded: int
) -> _Item:
    """A node: its name, limits, reports and folded count; its observers in the tooltip."""
    scene.legend[kind] = None
    name = node.name.value
    lines = _compact_details(node, folded, scene) if scene.compact else _details(node, folded)
    tip = [f"{name}: {CLASS_NAMES[kind]}"]
    if node.drives:
        tip.append("drives " + ", ".join(h.value for h in node.drives))
    if node.diagnostics:
        tip.append("reports " + ", ".join(d.value for d in node.diagnostics))
    tip += _watch_lines(marking.watched.get(name, []))
    attrs, warn = _marked(name, STYLE[kind], marking, scene, tip)
    if name == marking.focus:
        attrs += f', penwidth=3, color="{COLOURS["focus"]}"'
    shown = name[len(cluster) + 1 :] if cluster else _short(name, scene.prefix)
    label = _label(shown, lines, warn, dark=_dark_fill(name, kind, marking.health))
    return _Item(name, attrs, label, "\n".join(tip), cluster)


def _dark_fill(name: str, kind: str, health: Marks | None) -> bool:
    """Whether the node's fill is dark (white text): an SN's grey, or a faulty one's red,
    unless a diagnosis fills it orange (black text)."""
    if health is not None and name in health.suspect:
        return False
    return kind == "sn" or (health is not None and name in health.faulty)


def _details(node: Node, folded: int) -> list[str]:
    """The lines under a node's name: its limits, reports and folded topics."""
    lines = []
    limits = format_limits(node.limits)
    if limits:
        lines.append(limits.replace(", ", " · "))
    if node.diagnostics:
        lines.append("reports " + ", ".join(d.value for d in node.diagnostics))
    if folded:
        lines.append(f"+{folded} topic{'s' if folded != 1 else ''}")
    return lines


def _compact_details(node: Node, folded: int, scene: _Scene) -> list[str]:
    """One line, ``10 % · 64 MB · +2``: the legend says what each part is; the reports
    are in the tooltip."""
    parts = []
    if node.limits.cpu is not None:
        parts.append(f"{format_number(node.limits.cpu)} %")
    if node.limits.mem is not None:
        parts.append(format_mem(node.limits.mem))
    if folded:
        parts.append(f"+{folded}")
    if parts:
        scene.legend["details"] = None
    return [" · ".join(parts)] if parts else []


def _watch_lines(watch_list: list[Watch]) -> list[str]:
    return [f"watched: {w.text} ({w.kind})" for w in watch_list]


def _marked(
    name: str, attrs: str, marking: _Marking, scene: _Scene, tip: list[str]
) -> tuple[str, str]:
    """The attributes with the coverage and health marks, and a warning line for the label."""
    warn = ""
    health = marking.health
    modes = marking.undetected.get(name)
    if modes:
        style = "rounded,filled,dashed" if scene.compact else "filled,dashed"
        attrs += f', style="{style}", penwidth=2, color="{COLOURS["undetected"]}"'
        warn = "unseen: " + ", ".join(modes)
        tip.append(f"no observer detects its faults in mode {', '.join(modes)} (racc analyze)")
        scene.legend["undetected"] = None
    if health is None:
        return attrs, warn
    if name in health.faulty:
        attrs += f', fillcolor="{COLOURS["faulty"]}", fontcolor="#ffffff"'
        tip.append("diagnosed faulty (in every minimal diagnosis)")
        scene.legend["faulty"] = None
    elif name in health.suspect:
        attrs += f', fillcolor="{COLOURS["suspect"]}", fontcolor="#000000"'
        tip.append("suspect (in some minimal diagnosis)")
        scene.legend["suspect"] = None
    if name in health.bad:
        attrs += f', penwidth=2.5, color="{COLOURS["bad"]}"'
        tip.append("an observer reads bad")
        scene.legend["bad"] = None
    elif name in health.good:
        attrs += f', penwidth=2, color="{COLOURS["good"]}"'
        scene.legend["good"] = None
    return attrs, warn


def _label(name: str, lines: list[str], warn: str, dark: bool) -> str:
    """The name alone (quoted), or an HTML label with small lines under it."""
    if not lines and not warn:
        return quote(name)
    body = [html_text(name)]
    body += [f'<FONT POINT-SIZE="8">{html_text(line)}</FONT>' for line in lines]
    if warn:
        colour = "#ffcdd2" if dark else COLOURS["undetected"]
        body.append(f'<FONT POINT-SIZE="8" COLOR="{colour}">{html_text(warn)}</FONT>')
    # Graphviz spaces the lines by its own font metrics, tighter than the fonts a browser or
    # its rasteriser uses: a thin empty line keeps the name's underscores off the digits.
    return "<" + body[0] + NAME_GAP + "<BR/>".join(body[1:]) + ">"


def _topic_line(name: str, topic: Topic | None, prefix: str, watch_list: list[Watch]) -> str:
    """``/pose @ 10 Hz``, ``~`` after a topic in a related pair."""
    rate = _rate(topic)
    text = _short(name, prefix) + (f" @ {rate}" if rate else "")
    if any(w.kind in ("BiQObs", "IObs") for w in watch_list):
        text += " ~"
    return text


def _topic_colour(key: str, watched: bool, health: Marks | None) -> str:
    if health is not None and key in health.bad:
        return COLOURS["bad"]
    if health is not None and key in health.good:
        return COLOURS["good"]
    return COLOURS["watched"] if watched else COLOURS["unwatched"]


def _draw_topics(
    top: _Topology,
    visible: list[str],
    shown: set[str],
    scene: _Scene,
    watched: Mapping[str, list[Watch]],
    health: Marks | None,
    prefix: str,
) -> None:
    """Topic boxes and every publish/subscribe arrow between drawn nodes."""
    lines: dict[str, str] = {}  # topic -> its HTML line
    tips: dict[str, str] = {}
    wires: dict[tuple[str, str], list[str]] = {}
    owners = {item.id: item.cluster for item in scene.items}  # a box joins its publisher
    for name in visible:
        key = TOPIC_ID + name
        topic = top.topics.get(name)
        watch_list = watched.get(key, [])
        colour = _topic_colour(key, bool(watch_list), health)
        _topic_legend(scene, watch_list, key, health)
        text = html_text(_topic_line(name, topic, prefix, watch_list))
        bold = health is not None and key in health.bad
        lines[name] = f'<FONT COLOR="{colour}">{"<B>" + text + "</B>" if bold else text}</FONT>'
        details = [d for d in ((topic.msg_type if topic else None), _rate(topic)) if d]
        tip = f"{name} ({', '.join(details)})" if details else name
        tips[name] = "; ".join([tip, *(f"{w.text} ({w.kind})" for w in watch_list)])
        pubs = [p for p in top.publishers.get(name, ()) if p in shown]
        subs = [s for s in top.subscribers.get(name, []) if s in shown]
        if pubs and subs and len(pubs) * len(subs) <= MAX_WIRE_PAIRS:
            for pub in pubs:
                for sub in subs:
                    wires.setdefault((pub, sub), []).append(name)
            continue
        loose = not (top.publishers.get(name) and top.subscribers.get(name))
        kind = "loose_topic" if loose else "topic"
        scene.legend[kind] = None
        tid = quote(key)
        cluster = owners.get((pubs or subs or [""])[0], "")
        scene.items.append(_Item(key, STYLE[kind], f"<{lines[name]}>", tips[name], cluster))
        scene.edges += [
            f"  {quote(p)} -> {tid} [{EDGE_STYLE['publish']}, "
            f"tooltip={quote(f'{p} publishes {tips[name]}')}];\n"
            for p in pubs
        ]
        scene.edges += [
            f"  {tid} -> {quote(s)} [tooltip={quote(f'{s} subscribes {tips[name]}')}];\n"
            for s in subs
        ]
    for (pub, sub), carried in wires.items():
        scene.legend["wire"] = None
        shown_lines = [lines[t] for t in carried[:MAX_LABEL_LINES]]
        if len(carried) > MAX_LABEL_LINES:
            shown_lines.append(f"+{len(carried) - MAX_LABEL_LINES} more")
        label = "<" + "<BR/>".join(shown_lines) + ">"
        tip = quote(f"{pub} → {sub}: " + ", ".join(tips[t] for t in carried))
        scene.edges.append(f"  {quote(pub)} -> {quote(sub)} [label={label}, tooltip={tip}];\n")


def _topic_legend(scene: _Scene, watch_list: list[Watch], key: str, health: Marks | None) -> None:
    if not watch_list:
        scene.legend["unwatched"] = None
    if any(w.kind in ("BiQObs", "IObs") for w in watch_list):
        scene.legend["related"] = None
    if health is not None and key in health.bad:
        scene.legend["bad_topic"] = None
    elif health is not None and key in health.good:
        scene.legend["good_topic"] = None


def _relations(model: Model, scene: _Scene) -> None:
    pairs = [f"{r.a.text} ~ {r.b.text}" for r in model.related]
    pairs += [
        f"{i.a.text} ~ {i.b.text} within {format_number(i.max_diff)}" for i in model.intervals
    ]
    if len(pairs) > MAX_RELATIONS_SHOWN:
        extra = len(pairs) - MAX_RELATIONS_SHOWN + 1
        pairs = [*pairs[: MAX_RELATIONS_SHOWN - 1], f"+{extra} more (racc diagram --all)"]
    scene.relations = pairs


def _summary(
    model: Model, undetected: Mapping[str, tuple[str, ...]], health: Marks | None
) -> _Scene:
    """One box per namespace: its nodes, hardware, topics and unseen faults; arrows between
    namespaces count the topics that cross."""
    scene = _Scene()
    groups = _namespace_groups(model)
    owner = {n.name.value: g for g, members in groups.items() for n in members}
    inside, crossing = _flows(model, owner)
    for g, members in groups.items():
        scene.items.append(_group_item(g, members, inside.get(g, 0), undetected, health, scene))
    scene.legend["group"] = None
    _flow_edges(scene, crossing, len(groups))
    why = f" (over {SUMMARY_ABOVE_NODES} nodes)" if len(model.nodes) > SUMMARY_ABOVE_NODES else ""
    scene.notes.append(
        f"summary of {len(model.nodes):,} nodes in {len(groups):,} namespaces{why}; "
        "racc diagram MODEL --focus NAME or --all draws the detail"
    )
    relations = len(model.related) + len(model.intervals)
    if relations:
        scene.relations = [f"{relations:,} related pairs and intervals"]
    return scene


def _namespace_groups(model: Model) -> dict[str, list[Node]]:
    """Nodes by the first namespace level below the one they all share."""
    prefix = _common_namespace([n.name.value for n in model.nodes])
    groups: dict[str, list[Node]] = {}
    for node in model.nodes:
        name = node.name.value
        rest = _short(name, prefix) if prefix else name.lstrip("/")
        head, sep, _ = rest.partition("/")
        group = (prefix + "/" + head if prefix else "/" + head) if sep else (prefix or "/")
        groups.setdefault(group, []).append(node)
    return groups


def _flows(
    model: Model, owner: Mapping[str, str]
) -> tuple[dict[str, int], dict[tuple[str, str], int]]:
    """Topics per namespace, and topics from one namespace's publishers to another's readers."""
    crossing: dict[tuple[str, str], int] = {}
    inside: dict[str, int] = {}
    top = _Topology(model)
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


def _group_item(
    group: str,
    members: list[Node],
    topics: int,
    undetected: Mapping[str, tuple[str, ...]],
    health: Marks | None,
    scene: _Scene,
) -> _Item:
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
    return _Item("group:" + group, attrs, label, group)


def _flow_edges(scene: _Scene, crossing: Mapping[tuple[str, str], int], boxes: int) -> None:
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


# The legend: each key, its symbol (an HTML table cell) and what it means.
LEGEND: dict[str, tuple[str, str]] = {
    "hardware": ('<TD BORDER="1" WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">hw</TD>', "hardware"),
    "switchable": (
        '<TD BORDER="1" WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">ch N</TD>',
        "switchable hardware, board channel N",
    ),
    "sn": (
        '<TD BORDER="1" STYLE="rounded" BGCOLOR="#555555" WIDTH="40" HEIGHT="16" '
        'FIXEDSIZE="TRUE"><FONT COLOR="#ffffff">SN</FONT></TD>',
        "driver of switchable hardware",
    ),
    "hn": (
        '<TD BORDER="1" STYLE="rounded" BGCOLOR="#bdbdbd" WIDTH="40" HEIGHT="16" '
        'FIXEDSIZE="TRUE">HN</TD>',
        "driver of other hardware",
    ),
    "n": (
        '<TD BORDER="1" STYLE="rounded" WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">N</TD>',
        "software node",
    ),
    "hardware_link": ('<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">┈┈┈</TD>', "drives"),
    "wire": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">──▶</TD>',
        "publisher to subscriber: topic @ rate (rate observed)",
    ),
    "topic": (
        '<TD BORDER="1" STYLE="rounded" COLOR="#7f9fbf" BGCOLOR="#e8f0f8" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="#1f4e79">/t</FONT></TD>',
        "topic of several publishers or readers",
    ),
    "loose_topic": (
        '<TD BORDER="1" STYLE="dashed" COLOR="#7f9fbf" BGCOLOR="#e8f0f8" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="#1f4e79">/t</FONT></TD>',
        "topic nobody publishes or nobody reads",
    ),
    "unwatched": (
        f'<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="{COLOURS["unwatched"]}">'
        "/t</FONT></TD>",
        "topic no observer watches",
    ),
    "related": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="#1f4e79">/t ~</FONT></TD>',
        "in a related pair (listed right)",
    ),
    "folded": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">+N</FONT></TD>',
        "folded topics of the node",
    ),
    "details": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">% · MB</FONT></TD>',
        "a node's cpu and memory limits",
    ),
    "namespace": (
        '<TD BORDER="1" STYLE="rounded" COLOR="#b0bec5" BGCOLOR="#f7f9fa" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">/ns</FONT></TD>',
        "namespace",
    ),
    "group": (
        '<TD BORDER="1" STYLE="rounded" COLOR="#607d8b" BGCOLOR="#f4f6f8" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">/ns</FONT></TD>',
        "namespace: its nodes and topics; arrows count topics between",
    ),
    "undetected": (
        f'<TD BORDER="1" STYLE="rounded,dashed" COLOR="{COLOURS["undetected"]}" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">unseen</FONT></TD>',
        "a fault no observer detects (racc analyze)",
    ),
    "faulty": (
        f'<TD BORDER="1" STYLE="rounded" BGCOLOR="{COLOURS["faulty"]}" WIDTH="40" HEIGHT="16" '
        'FIXEDSIZE="TRUE"><FONT COLOR="#ffffff">c</FONT></TD>',
        "diagnosed faulty (every diagnosis)",
    ),
    "suspect": (
        f'<TD BORDER="1" STYLE="rounded" BGCOLOR="{COLOURS["suspect"]}" WIDTH="40" HEIGHT="16" '
        'FIXEDSIZE="TRUE">c</TD>',
        "suspect (some diagnosis)",
    ),
    "bad": (
        f'<TD BORDER="2" STYLE="rounded" COLOR="{COLOURS["bad"]}" WIDTH="40" HEIGHT="20" '
        'FIXEDSIZE="TRUE">c</TD>',
        "an observer of it reads bad",
    ),
    "good": (
        f'<TD BORDER="2" STYLE="rounded" COLOR="{COLOURS["good"]}" WIDTH="40" HEIGHT="20" '
        'FIXEDSIZE="TRUE">c</TD>',
        "its observers read good",
    ),
    "bad_topic": (
        f'<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="{COLOURS["bad"]}"><B>/t</B>'
        "</FONT></TD>",
        "topic an observer reads bad",
    ),
    "good_topic": (
        f'<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="{COLOURS["good"]}">/t'
        "</FONT></TD>",
        "topic its observers read good",
    ),
}
LEGEND_PER_ROW = 3


def _legend_rows(keys: Iterable[str]) -> list[str]:
    """The legend's table rows, the keys in LEGEND's order, LEGEND_PER_ROW to a row."""
    used = [k for k in LEGEND if k in set(keys)]
    cells = [f'{LEGEND[k][0]}<TD ALIGN="LEFT">{html_text(LEGEND[k][1])}</TD>' for k in used]
    return ["".join(cells[i : i + LEGEND_PER_ROW]) for i in range(0, len(cells), LEGEND_PER_ROW)]


def _relation_rows(pairs: list[str]) -> list[str]:
    columns = [
        pairs[i : i + RELATIONS_PER_COLUMN] for i in range(0, len(pairs), RELATIONS_PER_COLUMN)
    ]
    height = len(columns[0]) if columns else 0
    return [
        "".join(f'<TD ALIGN="LEFT">{html_text(c[r]) if r < len(c) else ""}</TD>' for c in columns)
        for r in range(height)
    ]


def _node_statement(item: _Item, indent: str) -> str:
    return (
        f"{indent}{quote(item.id)} [{item.attrs}, label={item.label}, "
        f"tooltip={quote(item.tooltip)}];\n"
    )


def _cluster_text(clusters: Mapping[str, list[_Item]], prefix: str) -> str:
    """Each namespace below ``prefix`` a cluster, nested as the names nest; items outside
    any at the top.  A namespace holding only other namespaces gets a cluster when two or
    more of them share it."""
    spaces = set(clusters) - {""}
    for space in sorted(spaces):
        parent = namespace(space)
        while len(parent) > len(prefix) and parent not in spaces:
            if sum(1 for s in spaces if s.startswith(parent + "/")) > 1:
                spaces.add(parent)
            parent = namespace(parent)
    children: dict[str, list[str]] = {}
    for space in sorted(spaces):
        parent = namespace(space)
        while parent and parent not in spaces:
            parent = namespace(parent)
        children.setdefault(parent, []).append(space)
    shown_from = {space: prefix for space in children.get("", [])}

    def body(space: str, depth: int) -> list[str]:
        indent = "  " * depth
        out = [_node_statement(item, indent) for item in clusters.get(space, [])]
        for child in children.get(space, []):
            shown = child[len(space or shown_from.get(child, "")) + 1 :] or child
            out.append(
                f"{indent}subgraph {quote('cluster_' + child)} {{\n"
                f'{indent}  label={quote(shown)}; tooltip={quote(child)}; style="rounded,filled"; '
                f'fillcolor="#f7f9fa"; color="#b0bec5"; fontsize=10; fontcolor="#455a64";\n'
            )
            out += body(child, depth + 1)
            out.append(f"{indent}}}\n")
        return out

    return "".join(body("", 1))


def _write(model: Model, scene: _Scene, clusters: Mapping[str, list[_Item]], summary: bool) -> str:
    if not clusters:
        clusters = {"": scene.items}
    return render(
        "architecture.dot.j2",
        name=quote(model.name.value),
        caption=html_text(f"robot {model.name.value}"),
        notes=[html_text(n) for n in scene.notes],
        legend=_legend_rows(scene.legend),
        relations=_relation_rows(scene.relations),
        statements=_cluster_text(clusters, scene.prefix),
        newrank=len(clusters) > NEWRANK_ABOVE_CLUSTERS or scene.compact,
        compact=scene.compact,
        edges="".join(scene.edges),
        summary=summary,
    )
