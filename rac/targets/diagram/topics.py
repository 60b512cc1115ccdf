"""Topics: which are folded into a count on their node, and the arrows and topic boxes
of the others; the related pairs of the caption."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from rac.fmt import format_number
from rac.ir import Model, Topic
from rac.targets.coverage import TOPIC_ID, Marks, Watch, is_infrastructure
from rac.targets.diagram.layers import lay_out
from rac.targets.diagram.scene import ARROW, COLOURS, EDGE_STYLE, STYLE, Item, Scene, arrow
from rac.targets.diagram.text import MAX_SHOWN_CHARS, elide, html_text, quote
from rac.targets.diagram.topology import Topology, rate_text, short

# A topic with more publisher/subscriber pairs than this becomes a node of its own: one
# label and n+m arrows instead of n*m arrows each repeating the label.
MAX_WIRE_PAIRS = 2
# An arrow lists this many topics; the rest are counted ("+12 more") and in its tooltip.
MAX_LABEL_LINES = 4
# The caption lists this many related pairs; the rest are counted.
MAX_RELATIONS_SHOWN = 24
# A tooltip lists this many of a topic's observers; the rest are counted.
MAX_TIP_WATCHES = 12


def fold(
    top: Topology,
    shown: set[str],
    focused: bool,
    watched: Mapping[str, list[Watch]],
    everything: bool,
    scene: Scene,
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
        listed = ", ".join(short(t, scene.prefix) for t in infrastructure[:6])
        more = f" and {len(infrastructure) - 6} more" if len(infrastructure) > 6 else ""
        scene.notes.append(f"folded: unobserved infrastructure topics {listed}{more}")
    if single or infrastructure:
        scene.legend["folded"] = None
        scene.notes.append("--all draws every topic")
    return visible, folded


def topic_line(name: str, topic: Topic | None, prefix: str, watch_list: list[Watch]) -> str:
    """``/pose @ 10 Hz``, ``~`` after a topic in a related pair."""
    rate = rate_text(topic)
    text = elide(short(name, prefix)) + (f" @ {rate}" if rate else "")
    if any(w.kind in ("BiQObs", "IObs") for w in watch_list):
        text += " ~"
    return text


def topic_colour(key: str, watched: bool, health: Marks | None) -> str:
    if health is not None and key in health.bad:
        return COLOURS["bad"]
    if health is not None and key in health.good:
        return COLOURS["good"]
    return COLOURS["watched"] if watched else COLOURS["unwatched"]


@dataclass(frozen=True, slots=True)
class TopicLook:
    """How one topic is written: its line (HTML, coloured by its observers, bold when one
    reads bad), its tooltip, and how much a reviewer needs to see it (0 first)."""

    line: str
    tip: str
    weight: int  # 0: an observer reads it bad, 1: watched, 2: nothing watches it


def topic_looks(
    top: Topology,
    visible: list[str],
    scene: Scene,
    watched: Mapping[str, list[Watch]],
    health: Marks | None,
    prefix: str,
) -> dict[str, TopicLook]:
    looks: dict[str, TopicLook] = {}
    for name in visible:
        key = TOPIC_ID + name
        topic = top.topics.get(name)
        watch_list = watched.get(key, [])
        colour = topic_colour(key, bool(watch_list), health)
        topic_legend(scene, watch_list, key, health)
        text = html_text(topic_line(name, topic, prefix, watch_list), MAX_SHOWN_CHARS + 16)
        bad = health is not None and key in health.bad
        line = f'<FONT COLOR="{colour}">{"<B>" + text + "</B>" if bad else text}</FONT>'
        details = [d for d in ((topic.msg_type if topic else None), rate_text(topic)) if d]
        tip = f"{name} ({', '.join(details)})" if details else name
        watches_shown = [f"{w.text} ({w.kind})" for w in watch_list[:MAX_TIP_WATCHES]]
        if len(watch_list) > MAX_TIP_WATCHES:
            watches_shown.append(f"+{len(watch_list) - MAX_TIP_WATCHES} more observers")
        weight = 0 if bad else 1 if watch_list else 2
        looks[name] = TopicLook(line, "; ".join([tip, *watches_shown]), weight)
    return looks


def topic_box(
    name: str, look: TopicLook, top: Topology, scene: Scene, cluster: str, extra: str = ""
) -> str:
    """A topic's own box (dashed when nobody publishes or nobody reads it); its DOT id."""
    loose = not (top.publishers.get(name) and top.subscribers.get(name))
    kind = "loose_topic" if loose else "topic"
    scene.legend[kind] = None
    key = TOPIC_ID + name
    label = f"<{look.line}{extra}>"
    scene.items.append(Item(key, STYLE[kind], label, look.tip, cluster))
    return quote(key)


def draw_topics(
    model: Model,
    top: Topology,
    visible: list[str],
    shown: set[str],
    scene: Scene,
    watched: Mapping[str, list[Watch]],
    health: Marks | None,
    prefix: str,
) -> None:
    """Topic boxes and every publish/subscribe arrow between drawn nodes, laid out by data
    flow (:func:`rac.targets.diagram.layers.lay_out`)."""
    looks = topic_looks(top, visible, scene, watched, health, prefix)
    wires: dict[tuple[str, str], list[str]] = {}
    owners = {item.id: item.cluster for item in scene.items}  # a box joins its publisher
    boxed: list[tuple[str, str, str]] = []  # (tail, head, attributes) of a box's arrows
    for name in visible:
        look = looks[name]
        pubs = [p for p in top.publishers.get(name, ()) if p in shown]
        subs = [s for s in top.subscribers.get(name, []) if s in shown]
        if pubs and subs and len(pubs) * len(subs) <= MAX_WIRE_PAIRS:
            for pub in pubs:
                for sub in subs:
                    wires.setdefault((pub, sub), []).append(name)
            continue
        topic_box(name, look, top, scene, owners.get((pubs or subs or [""])[0], ""))
        key = TOPIC_ID + name
        boxed += [
            (p, key, f"{EDGE_STYLE['publish']}, tooltip={quote(f'{p} publishes {look.tip}')}")
            for p in pubs
        ]
        boxed += [(key, s, f"tooltip={quote(f'{s} subscribes {look.tip}')}") for s in subs]
    nodes = [n.name.value for n in model.nodes if n.name.value in shown]
    boxes = list(dict.fromkeys(t for t, _, _ in boxed if t.startswith(TOPIC_ID)))
    boxes += [h for _, h, _ in boxed if h.startswith(TOPIC_ID) and h not in boxes]
    layout = lay_out(model, nodes, boxes, [*wires, *((t, h) for t, h, _ in boxed)])
    scene.sources = layout.sources
    for tail, head, attrs in boxed:
        arrow(scene, tail, head, attrs, (tail, head) in layout.back)
    for (pub, sub), carried in wires.items():
        scene.legend["wire"] = None
        shown_lines = [looks[t].line for t in carried[:MAX_LABEL_LINES]]
        if len(carried) > MAX_LABEL_LINES:
            shown_lines.append(f"+{len(carried) - MAX_LABEL_LINES} more")
        tip = f"{pub}{ARROW}{sub}: " + ", ".join(looks[t].tip for t in carried)
        named = ("<BR/>".join(shown_lines), tip, f"{pub}{ARROW}{sub}")
        arrow(scene, pub, sub, f"tooltip={quote(tip)}", (pub, sub) in layout.back, named)
    if layout.back:
        scene.legend["feedback"] = None


def topic_legend(scene: Scene, watch_list: list[Watch], key: str, health: Marks | None) -> None:
    if not watch_list:
        scene.legend["unwatched"] = None
    if any(w.kind in ("BiQObs", "IObs") for w in watch_list):
        scene.legend["related"] = None
    if health is not None and key in health.bad:
        scene.legend["bad_topic"] = None
    elif health is not None and key in health.good:
        scene.legend["good_topic"] = None


def relation_list(model: Model, scene: Scene) -> None:
    pairs = [f"{elide(r.a.text)} ~ {elide(r.b.text)}" for r in model.related]
    pairs += [
        f"{elide(i.a.text)} ~ {elide(i.b.text)} within {format_number(i.max_diff)}"
        for i in model.intervals
    ]
    if len(pairs) > MAX_RELATIONS_SHOWN:
        extra = len(pairs) - MAX_RELATIONS_SHOWN + 1
        pairs = [*pairs[: MAX_RELATIONS_SHOWN - 1], f"+{extra} more (racc diagram --all)"]
    scene.relations = pairs
