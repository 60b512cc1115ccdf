"""Who publishes and reads what, namespaces, and the neighbourhood of a focus."""

from __future__ import annotations

from rac.fmt import format_number
from rac.ir import Model, Node, Topic


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


def rate_text(topic: Topic | None) -> str:
    if topic is None or topic.rate_hz is None:
        return ""
    return f"{format_number(topic.rate_hz)} Hz"


class Topology:
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


def focus_namespace(model: Model, top: Topology, focus: str) -> str | None:
    """The namespace ``focus`` names (``/robot_41/drivers``, a trailing ``/`` allowed), if it
    names no node, hardware or topic and some node lives under it."""
    if focus in top.topics or focus in top.publishers or focus in top.subscribers:
        return None
    names = {n.name.value for n in model.nodes} | {h.name.value for h in model.hardware}
    space = focus.rstrip("/")
    if focus in names or not space.startswith("/"):
        return None
    inside = any(n.name.value.startswith(space + "/") for n in model.nodes)
    return space if inside else None


def focus_set(model: Model, top: Topology, focus: str, depth: int) -> set[str] | None:
    """The nodes within ``depth`` hops upstream or downstream of ``focus`` (a node, a
    device's driver, a topic's ends, or every node of a namespace); None: unknown."""
    by_node = model.node_by_name()
    drivers = {h.value: n.name.value for n in model.nodes for h in n.drives}
    space = focus_namespace(model, top, focus)
    if focus in by_node:
        start = {focus}
    elif focus in drivers:
        start = {drivers[focus]}
    elif focus in top.publishers or focus in top.subscribers or focus in top.topics:
        ends = [*top.publishers.get(focus, ()), *top.subscribers.get(focus, [])]
        start, depth = set(ends), max(depth - 1, 0)
    elif space is not None:
        start = {n.name.value for n in model.nodes if n.name.value.startswith(space + "/")}
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


def common_namespace(names: list[str]) -> str:
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


def short(name: str, prefix: str) -> str:
    return name[len(prefix) + 1 :] if prefix and name.startswith(prefix + "/") else name


def cluster_of(name: str, prefix: str) -> str:
    space = namespace(name)
    return "" if space == prefix else space


def count_text(n: int, noun: str) -> str:
    """``1 reader``, ``3 readers``."""
    return f"{n:,} {noun}" if n == 1 else f"{n:,} {noun}s"
