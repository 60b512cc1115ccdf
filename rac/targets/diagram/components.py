"""Nodes and hardware: Figure 3.1's shapes and fills, their details, and the marks of
coverage (faults no observer detects) and of a diagnosis."""

from __future__ import annotations

from collections.abc import Mapping

from rac.fmt import format_limits, format_mem, format_number
from rac.ir import Model, Node
from rac.targets.coverage import Marks, Watch
from rac.targets.diagram.scene import CLASS_NAMES, COLOURS, EDGE_STYLE, STYLE, Item, Marking, Scene
from rac.targets.diagram.text import elide, html_text, quote, shown
from rac.targets.diagram.topology import cluster_of, node_class, short

NAME_GAP = '<BR/><FONT POINT-SIZE="3"> </FONT><BR/>'


def draw_components(
    model: Model,
    nodes: list[Node],
    scene: Scene,
    marking: Marking,
    folded: Mapping[str, int],
) -> None:
    switchable = {h.name.value for h in model.hardware if h.switchable}
    hardware = model.hardware_by_name()
    driven: dict[str, str] = {}  # device -> its driver's cluster
    first = len(scene.items)  # hardware goes before the nodes: above its driver
    for node in nodes:
        kind = node_class(node, switchable, set(hardware)) if node.drives else "n"
        name = node.name.value
        cluster = cluster_of(name, scene.prefix) if scene.clusters else ""
        scene.items.append(node_item(node, kind, cluster, scene, marking, folded.get(name, 0)))
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
        tip += watch_lines(marking.watched.get(name, []))
        attrs, warn = marked(name, STYLE["hardware"], marking, scene, tip)
        label = node_label(name, [f"ch {hw.channel}"] if hw.switchable else [], warn, dark=False)
        scene.items.insert(first, Item(name, attrs, label, "\n".join(tip), driven.get(name, "")))
        first += 1


def node_item(
    node: Node, kind: str, cluster: str, scene: Scene, marking: Marking, folded: int
) -> Item:
    """A node: its name, limits, reports and folded count; its observers in the tooltip."""
    scene.legend[kind] = None
    name = node.name.value
    lines = compact_details(node, folded, scene) if scene.compact else detail_lines(node, folded)
    tip = [f"{name}: {CLASS_NAMES[kind]}"]
    if node.drives:
        tip.append("drives " + ", ".join(h.value for h in node.drives))
    if node.diagnostics:
        tip.append("reports " + ", ".join(d.value for d in node.diagnostics))
    tip += watch_lines(marking.watched.get(name, []))
    attrs, warn = marked(name, STYLE[kind], marking, scene, tip)
    if name == marking.focus:
        attrs += f', penwidth=3, color="{COLOURS["focus"]}"'
    shown = name[len(cluster) + 1 :] if cluster else short(name, scene.prefix)
    label = node_label(shown, lines, warn, dark=dark_fill(name, kind, marking.health))
    return Item(name, attrs, label, "\n".join(tip), cluster, shown)


def dark_fill(name: str, kind: str, health: Marks | None) -> bool:
    """Whether the node's fill is dark (white text): an SN's grey, or a faulty one's red,
    unless a diagnosis fills it orange (black text)."""
    if health is not None and name in health.suspect:
        return False
    return kind == "sn" or (health is not None and name in health.faulty)


def detail_lines(node: Node, folded: int) -> list[str]:
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


def compact_details(node: Node, folded: int, scene: Scene) -> list[str]:
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


def watch_lines(watch_list: list[Watch]) -> list[str]:
    return [f"watched: {w.text} ({w.kind})" for w in watch_list]


def marked(
    name: str, attrs: str, marking: Marking, scene: Scene, tip: list[str]
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


def node_label(name: str, lines: list[str], warn: str, dark: bool) -> str:
    """The name alone (quoted), or an HTML label with small lines under it."""
    if not lines and not warn:
        return quote(elide(name))
    body = [shown(name)]
    body += [f'<FONT POINT-SIZE="8">{html_text(line)}</FONT>' for line in lines]
    if warn:
        colour = "#ffcdd2" if dark else COLOURS["undetected"]
        body.append(f'<FONT POINT-SIZE="8" COLOR="{colour}">{html_text(warn)}</FONT>')
    # Graphviz spaces the lines by its own font metrics, tighter than the fonts a browser or
    # its rasteriser uses: a thin empty line keeps the name's underscores off the digits.
    return "<" + body[0] + NAME_GAP + "<BR/>".join(body[1:]) + ">"
