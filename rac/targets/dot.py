"""architecture.dot: the Graphviz diagram, drawn with Figure 3.1's conventions.

Hardware are rectangles, nodes ellipses filled by class (SN dark grey, HN grey,
N white), publish/subscribe arrows carry their topics, dotted lines join a
driver to its hardware; a caption under the drawing holds the robot's name, the
legend and the related signals.  This module decides *what* is drawn (classes,
which topics become boxes, merged arrows, every string quoted or escaped); the
template decides how it looks.  Everything follows declaration order, so the
output is byte-identical from run to run.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

from rac.fmt import format_limits, format_number
from rac.ir import Interval, Model, Node, Related, Topic
from rac.pipeline import Compiled
from rac.targets import EmitOptions
from rac.targets.templating import render

# A topic with more publisher/subscriber pairs than this becomes a node of its
# own: one label and n+m arrows instead of n*m arrows each repeating the label.
MAX_WIRE_PAIRS = 2

# The prefix keeps topic boxes apart from components (which share one namespace
# already): ':' is in neither a ROS name nor a hardware name.
TOPIC_ID = "topic:"

# Related pairs are listed in the caption, this many to a column.
RELATIONS_PER_COLUMN = 6


_DOT_SPECIAL = re.compile(r'[\\"\r\n]')


def quote(text: str) -> str:
    """A DOT double-quoted string whose escString value is ``text`` verbatim.

    Backslashes are doubled so Graphviz's label escapes (``\\N``, ``\\G``,
    ``\\l``…) cannot fire by accident; a line break becomes DOT's ``\\n``.
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


def _label(*lines: str) -> str:
    return quote("\n".join(lines))


# A node statement's parts, each quoted: id, style key of the template, label, tooltip.  Plain
# tuples: a large model draws tens of thousands of them.
DotNode = tuple[str, str, str, str]
# An edge statement's parts: tail and head ids, style key, label (quoted, or None for an
# unlabelled edge), tooltip (quoted).
DotEdge = tuple[str, str, str, str | None, str]


def _rate(topic: Topic | None) -> str:
    if topic is None or topic.rate_hz is None:
        return ""
    return f"{format_number(topic.rate_hz)} Hz"


def _topic_line(name: str, topic: Topic | None) -> str:
    """``/pose @ 10 Hz`` as in the DSL, or the bare name of an irregular topic."""
    rate = _rate(topic)
    return f"{name} @ {rate}" if rate else name


def _topic_tooltip(name: str, topic: Topic | None) -> str:
    details = [d for d in ((topic.msg_type if topic else None), _rate(topic)) if d]
    return f"{name} ({', '.join(details)})" if details else name


def node_class(node: Node, switchable: set[str], hardware: set[str]) -> str:
    """SN drives switchable hardware, HN only other hardware, N none (docs/spec.md)."""
    drives = {h.value for h in node.drives}
    if drives & switchable:
        return "sn"
    if drives & hardware:
        return "hn"
    return "n"


_CLASS_NAMES = {
    "sn": "driver of switchable hardware (SN)",
    "hn": "hardware driver (HN)",
    "n": "software node (N)",
}


def _node_tooltip(node: Node, kind: str) -> str:
    lines = [f"{node.name.value}: {_CLASS_NAMES[kind]}"]
    if node.drives:
        lines.append("drives " + ", ".join(h.value for h in node.drives))
    limits = format_limits(node.limits)
    if limits:
        lines.append(f"limits {limits}")
    if node.diagnostics:
        lines.append("reports " + ", ".join(d.value for d in node.diagnostics))
    return quote("\n".join(lines))


def _relation_lines(related: tuple[Related, ...], intervals: tuple[Interval, ...]) -> list[str]:
    lines = [f"{r.a.text} ~ {r.b.text}" for r in related]
    lines += [f"{i.a.text} ~ {i.b.text} within {format_number(i.max_diff)}" for i in intervals]
    return lines


@dataclass(frozen=True, slots=True)
class Diagram:
    name: str  # quoted
    hardware: tuple[DotNode, ...]
    nodes: tuple[DotNode, ...]
    topics: tuple[DotNode, ...]
    edges: tuple[DotEdge, ...]
    beside: tuple[tuple[str, ...], ...]  # quoted ids drawn in one rank: a driver, its hardware
    caption: str  # HTML text: the robot's name
    relations: tuple[tuple[str, ...], ...]  # HTML text, rows of the related-signals note


class _Quoted(dict[str, str]):
    """``quote`` of each string asked for, remembered: ids recur in many statements."""

    def __missing__(self, text: str) -> str:
        self[text] = quoted = quote(text)
        return quoted


def _hardware(model: Model) -> tuple[DotNode, ...]:
    out = []
    for h in model.hardware:
        name = h.name.value
        if h.switchable:
            label, tip = (
                _label(name, f"ch {h.channel}"),
                f"{name}: switchable, board channel {h.channel}",
            )
        else:
            label, tip = _label(name), f"{name}: hardware"
        out.append((quote(name), "hardware", label, quote(tip)))
    return tuple(out)


def _topics(model: Model, quoted: _Quoted) -> tuple[list[DotNode], list[DotEdge]]:
    """Topic boxes and every publish/subscribe arrow."""
    topics = model.topic_by_name()
    publishers = model.publishers()
    subscribers: dict[str, list[str]] = {}
    for node in model.nodes:
        for ref in node.subscribes:
            subscribers.setdefault(ref.value, []).append(node.name.value)

    # Topic names in declaration order, then any a node names without declaring
    # it (only an unvalidated model has those), so no topic goes undrawn.
    names = list(topics)
    named = {ref.value for node in model.nodes for ref in node.subscribes}
    named.update(p.topic.value for node in model.nodes for p in node.publishes)
    if not named.issubset(topics):  # the rare case: keep the order the nodes name them in
        for node in model.nodes:
            for ref in [*node.subscribes, *(p.topic for p in node.publishes)]:
                if ref.value not in topics and ref.value not in names:
                    names.append(ref.value)

    # A topic's line ("/pose @ 10 Hz") and tooltip, made once per topic.
    lines: dict[str, str] = {}
    tooltips: dict[str, str] = {}
    for name in names:
        topic = topics.get(name)
        rate = _rate(topic)
        lines[name] = f"{name} @ {rate}" if rate else name
        details = [d for d in ((topic.msg_type if topic else None), rate) if d]
        tooltips[name] = f"{name} ({', '.join(details)})" if details else name

    boxes: list[DotNode] = []
    box_edges: list[DotEdge] = []
    wires: dict[tuple[str, str], list[str]] = {}  # (publisher, subscriber) -> topics
    for name in names:
        pubs, subs = publishers.get(name, ()), subscribers.get(name, [])
        if pubs and subs and len(pubs) * len(subs) <= MAX_WIRE_PAIRS:
            for pub in pubs:
                for sub in subs:
                    wires.setdefault((pub, sub), []).append(name)
            continue
        tid = quote(TOPIC_ID + name)
        tip = tooltips[name]
        kind = "topic" if pubs and subs else "loose_topic"
        boxes.append((tid, kind, quote(lines[name]), quote(tip)))
        box_edges += [
            (quoted[p], tid, "publish", None, quote(f"{p} publishes {tip}")) for p in pubs
        ]
        box_edges += [
            (tid, quoted[s], "subscribe", None, quote(f"{s} subscribes {tip}")) for s in subs
        ]

    # Wires follow the order their first topic was declared in; a pair of nodes
    # joined by several topics gets one arrow listing them all.
    wire_edges: list[DotEdge] = []
    for (pub, sub), carried in wires.items():
        if len(carried) == 1:
            label, tips = quote(lines[carried[0]]), tooltips[carried[0]]
        else:
            label = _label(*(lines[t] for t in carried))
            tips = ", ".join(tooltips[t] for t in carried)
        tip = quote(f"{pub} → {sub}: {tips}")
        wire_edges.append((quoted[pub], quoted[sub], "wire", label, tip))
    return boxes, wire_edges + box_edges


def diagram(model: Model) -> Diagram:
    """The drawing of ``model``: every node, hardware and topic, nothing invisible."""
    switchable = {h.name.value for h in model.hardware if h.switchable}
    hardware_names = {h.name.value for h in model.hardware}
    hardware = _hardware(model)
    quoted = _Quoted()
    nodes: list[DotNode] = []
    for node in model.nodes:
        kind = node_class(node, switchable, hardware_names) if node.drives else "n"
        nid = quoted[node.name.value]  # its label too: one line, the name
        nodes.append((nid, kind, nid, _node_tooltip(node, kind)))
    boxes, flows = _topics(model, quoted)

    # Hardware is the tail, so a device is drawn just above its driver.
    links: list[DotEdge] = [
        (
            quoted[hw.value],
            quoted[node.name.value],
            "hardware_link",
            None,
            quote(f"{node.name.value} drives {hw.value}"),
        )
        for node in model.nodes
        if node.drives
        for hw in node.drives
        if hw.value in hardware_names
    ]
    # A device stands beside its driver (one rank), not a rank before it: the
    # dotted link stays short and the diagram no wider for it.
    beside = []
    for node in model.nodes:
        if not node.drives:
            continue
        devices = [quoted[h.value] for h in node.drives if h.value in hardware_names]
        if devices:
            beside.append((quoted[node.name.value], *devices))

    # The note lists pairs column by column; short columns are padded with "".
    lines = [html_text(line) for line in _relation_lines(model.related, model.intervals)]
    columns = [
        lines[i : i + RELATIONS_PER_COLUMN] for i in range(0, len(lines), RELATIONS_PER_COLUMN)
    ]
    height = len(columns[0]) if columns else 0
    relations = tuple(tuple(c[r] if r < len(c) else "" for c in columns) for r in range(height))

    return Diagram(
        name=quote(model.name.value),
        hardware=hardware,
        nodes=tuple(nodes),
        topics=tuple(boxes),
        edges=(*links, *flows),
        beside=tuple(beside),
        caption=html_text(f"robot {model.name.value}"),
        relations=relations,
    )


def node_statements(nodes: tuple[DotNode, ...], style: Mapping[str, str]) -> str:
    """``  ID [STYLE, label=…, tooltip=…];`` for each node, one a line.

    The template's loop, written in Python: a large model draws tens of thousands.
    """
    heads = {kind: f" [{attributes}, label=" for kind, attributes in style.items()}
    return "".join(
        [f"  {nid}{heads[kind]}{label}, tooltip={tip}];\n" for nid, kind, label, tip in nodes]
    )


def edge_statements(edges: tuple[DotEdge, ...], style: Mapping[str, str]) -> str:
    """``  TAIL -> HEAD [STYLE, label=…, tooltip=…];`` for each edge, one a line.

    An empty style and a missing label are left out.
    """
    heads = {
        kind: f" [{attributes}, " if attributes else " [" for kind, attributes in style.items()
    }
    return "".join(
        [
            f"  {tail} -> {head}{heads[kind]}label={label}, tooltip={tip}];\n"
            if label
            else f"  {tail} -> {head}{heads[kind]}tooltip={tip}];\n"
            for tail, head, kind, label, tip in edges
        ]
    )


def rank_statements(beside: tuple[tuple[str, ...], ...]) -> str:
    """``  { rank=same; A; B; }`` for each group of ids drawn in one rank."""
    return "".join([f"  {{ rank=same; {'; '.join(ids)}; }}\n" for ids in beside])


def emit_dot(compiled: Compiled, options: EmitOptions) -> str:
    return render(
        "architecture.dot.j2",
        d=diagram(compiled.model),
        node_statements=node_statements,
        edge_statements=edge_statements,
        rank_statements=rank_statements,
    )
