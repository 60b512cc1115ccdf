"""Topics: which are folded into a count on their node, and the arrows and topic boxes
of the others; the related pairs of the caption."""

from __future__ import annotations

from collections.abc import Mapping

from rac.fmt import format_number
from rac.ir import Model, Topic
from rac.targets.coverage import TOPIC_ID, Marks, Watch, is_infrastructure
from rac.targets.diagram.scene import COLOURS, EDGE_STYLE, STYLE, Item, Scene
from rac.targets.diagram.text import html_text, quote
from rac.targets.diagram.topology import Topology, rate_text, short

# A topic with more publisher/subscriber pairs than this becomes a node of its own: one
# label and n+m arrows instead of n*m arrows each repeating the label.
MAX_WIRE_PAIRS = 2
# An arrow lists this many topics; the rest are counted ("+12 more") and in its tooltip.
MAX_LABEL_LINES = 4
# The caption lists this many related pairs; the rest are counted.
MAX_RELATIONS_SHOWN = 24


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
    text = short(name, prefix) + (f" @ {rate}" if rate else "")
    if any(w.kind in ("BiQObs", "IObs") for w in watch_list):
        text += " ~"
    return text


def topic_colour(key: str, watched: bool, health: Marks | None) -> str:
    if health is not None and key in health.bad:
        return COLOURS["bad"]
    if health is not None and key in health.good:
        return COLOURS["good"]
    return COLOURS["watched"] if watched else COLOURS["unwatched"]


def draw_topics(
    top: Topology,
    visible: list[str],
    shown: set[str],
    scene: Scene,
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
        colour = topic_colour(key, bool(watch_list), health)
        topic_legend(scene, watch_list, key, health)
        text = html_text(topic_line(name, topic, prefix, watch_list))
        bold = health is not None and key in health.bad
        lines[name] = f'<FONT COLOR="{colour}">{"<B>" + text + "</B>" if bold else text}</FONT>'
        details = [d for d in ((topic.msg_type if topic else None), rate_text(topic)) if d]
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
        scene.items.append(Item(key, STYLE[kind], f"<{lines[name]}>", tips[name], cluster))
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
    pairs = [f"{r.a.text} ~ {r.b.text}" for r in model.related]
    pairs += [
        f"{i.a.text} ~ {i.b.text} within {format_number(i.max_diff)}" for i in model.intervals
    ]
    if len(pairs) > MAX_RELATIONS_SHOWN:
        extra = len(pairs) - MAX_RELATIONS_SHOWN + 1
        pairs = [*pairs[: MAX_RELATIONS_SHOWN - 1], f"+{extra} more (racc diagram --all)"]
    scene.relations = pairs
