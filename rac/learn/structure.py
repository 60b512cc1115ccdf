"""The structure of a learned model (Definition 9.2): nodes, hardware and topics, from a
base model, a computation graph or the recording; and what learning leaves out of it."""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from rac.ir import Hardware, Machine, Model, Name, Node, Publication, Topic
from rac.learn.graph import Exclusions, Graph
from rac.learn.options import LearnOptions
from rac.learn.recording import Recording, TopicData


def identifier(text: str) -> str:
    name = re.sub(r"[^A-Za-z0-9_\-]", "_", text).strip("_-") or "learned"
    return name if name[0].isalpha() or name[0] == "_" else f"r{name}"


def _structure_from_graph(graph: Graph) -> tuple[list[Node], list[Hardware]]:
    nodes = []
    placed = machines_from_graph(graph)[1]
    for g in sorted(graph.nodes, key=lambda n: n.name):
        subs = tuple(Name(t) for t in dict.fromkeys(g.subscriptions))
        pubs = tuple(
            Publication(Name(t), tuple(s for s in subs if s.value != t))
            for t in dict.fromkeys(g.publications)
        )
        where = Name(placed[g.name]) if g.name in placed else None
        nodes.append(
            Node(Name(g.name), tuple(Name(h) for h in g.drives), subs, pubs, machine=where)
        )
    declared = {h.name for h in graph.hardware}
    hardware = [Hardware(Name(h.name), h.switchable, h.channel) for h in graph.hardware]
    for h in sorted({d for g in graph.nodes for d in g.drives} - declared):
        hardware.append(Hardware(Name(h)))
    return nodes, hardware


def machines_from_graph(graph: Graph) -> tuple[tuple[Machine, ...], dict[str, str]]:
    """The machines of a graph whose nodes run on more than one host, and each node's
    machine (one host: nothing, the robot is one computer).  The host of most nodes comes
    first (a node without ``on`` runs there); a machine is named after its host."""
    hosts = [g.host for g in graph.nodes if g.host]
    if len(set(hosts)) < 2:
        return (), {}
    counts: dict[str, int] = {}
    for h in hosts:
        counts[h] = counts.get(h, 0) + 1
    ordered = sorted(counts, key=lambda h: (-counts[h], h))
    names: dict[str, str] = {}
    for host in ordered:
        base = re.sub(r"[^A-Za-z0-9_]", "_", host).strip("_") or "machine"
        base = base if base[0].isalpha() else f"host_{base}"
        name, i = base, 2
        while name in names.values():
            name, i = f"{base}_{i}", i + 1
        names[host] = name
    machines = tuple(Machine(Name(names[h]), address=h) for h in ordered)
    return machines, {g.name: names[g.host] for g in graph.nodes if g.host}


def _structure_from_recording(recording: Recording) -> list[Node]:
    published: dict[str, list[str]] = {}
    for t in recording.topics:
        for n in t.publishers:
            published.setdefault(n, []).append(t.name)
    return [
        Node(Name(n), publishes=tuple(Publication(Name(t)) for t in sorted(ts)))
        for n, ts in sorted(published.items())
    ]


def _topic_from_recording(data: TopicData) -> Topic:
    """The recorded topic with its varying fields: a constant signal relates to nothing."""
    return Topic(Name(data.name), data.msg_type, tuple(Name(f) for f in varying_fields(data)))


def varying_fields(data: TopicData) -> tuple[str, ...]:
    """The fields whose finite values change over the recording."""
    out = []
    for name, row in zip(data.fields, data.values, strict=True):
        finite = row[np.isfinite(row)]
        if finite.size and float(finite.max()) > float(finite.min()):
            out.append(name)
    return tuple(out)


def without_tools(
    recording: Recording, graph: Graph | None, exclusions: Exclusions, notes: list[str]
) -> tuple[Recording, Graph | None]:
    """The recording and graph without racc's own topics and nodes and ROS's tool nodes
    (a recording made while racc or ``rostopic echo`` ran holds them)."""
    topics = []
    left_out: set[str] = set()
    for t in recording.topics:
        owners = [f"/{p}" for p in t.publishers]
        if not exclusions.topic(t.name, owners):
            left_out.add(t.name)
            continue
        mine = tuple(p for p in t.publishers if exclusions.node(p))
        left_out.update(f"/{p}" for p in t.publishers if p not in mine)
        topics.append(replace(t, publishers=mine) if mine != t.publishers else t)
    if graph is not None:
        kept_nodes = []
        for g in graph.nodes:
            if not exclusions.node(g.name):
                left_out.add(f"/{g.name}")
                continue
            pubs = tuple(t for t in g.publications if exclusions.topic(t))
            subs = tuple(t for t in g.subscriptions if exclusions.topic(t))
            left_out.update(set(g.publications + g.subscriptions) - set(pubs + subs))
            kept_nodes.append(replace(g, publications=pubs, subscriptions=subs))
        graph = replace(graph, nodes=tuple(kept_nodes))
    if left_out:
        notes.append(
            "racc's own and ROS's tool topics and nodes left out (--include keeps them): "
            + ", ".join(sorted(left_out))
        )
    return replace(recording, topics=tuple(topics)), graph


def excluded(
    recording: Recording, graph: Graph | None, patterns: Sequence[str], notes: list[str]
) -> tuple[Recording, Graph | None]:
    """The recording and graph without what the user left out: topics matching an
    ``--exclude`` glob, and, with a graph, the recorded topics the graph does not name
    (they are not part of the robot the graph describes, and their names must not collide
    with its topics'); each named in a note."""
    graph_topics = None
    if graph is not None:
        graph_topics = {t for g in graph.nodes for t in (*g.publications, *g.subscriptions)}

    def matches(name: str) -> bool:
        return any(fnmatch.fnmatchcase(name, p) for p in patterns)

    by_user = sorted(t.name for t in recording.topics if matches(t.name))
    outside = sorted(
        t.name
        for t in recording.topics
        if graph_topics is not None and t.name not in graph_topics and not matches(t.name)
    )
    outside = sorted(set(outside) | {t for t in recording.skipped if graph_topics is not None})
    if by_user:
        notes.append(f"topics left out by --exclude: {', '.join(by_user)}")
    if outside:
        notes.append(f"recorded topics not in the --graph, left out: {', '.join(outside)}")
    gone = set(by_user) | set(outside)
    if graph is not None and patterns:
        nodes = []
        for g in graph.nodes:
            pubs = tuple(t for t in g.publications if not matches(t))
            subs = tuple(t for t in g.subscriptions if not matches(t))
            nodes.append(replace(g, publications=pubs, subscriptions=subs))
        graph = replace(graph, nodes=tuple(nodes))
    if not gone:
        return recording, graph
    topics = tuple(t for t in recording.topics if t.name not in gone)
    return replace(recording, topics=topics), graph


def _why_no_publishers(recording: Recording) -> str:
    """Why a recording names no publishing node, by the ROS version of its runs."""
    versions = {r.ros_version for r in recording.runs}
    ros2 = "ROS 2 bags do not record them"
    ros1 = (
        "its ROS 1 connections carry no callerid: the bag was written by a converter or a "
        "library, not by rosbag record"
    )
    if versions == {2}:
        return ros2
    if versions == {1}:
        return ros1
    return f"{ros2}, and {ros1.removeprefix('its ')}"


def structure(
    recording: Recording, base: Model | None, graph: Graph | None, notes: list[str]
) -> tuple[list[Node], list[Hardware], list[Topic]]:
    """Nodes, hardware and declared topics (Definition 9.2), from the best source given."""
    recorded = recording.topic_by_name()
    if base is not None:
        declared = {t.name.value for t in base.topics}
        ignored = sorted((set(recorded) | set(recording.skipped)) - declared)
        if ignored:
            notes.append(f"recorded topics not in the base model, ignored: {', '.join(ignored)}")
        return list(base.nodes), list(base.hardware), list(base.topics)
    if graph is not None:
        nodes, hardware = _structure_from_graph(graph)
    else:
        nodes, hardware = _structure_from_recording(recording), []
        notes.append(
            "no --base or --graph: subscriptions, hardware and drivers are not in a "
            "recording, so the model has none (give --base robot.ram or --graph graph.yaml)"
        )
        if not nodes:
            notes.append(
                f"the recording names no publishers ({_why_no_publishers(recording)}): the "
                "model has no nodes, so no rates or relations can be declared; they are in "
                "comments"
            )
    topics = [_topic_from_recording(recorded[n]) for n in sorted(recorded)]
    known = set(recorded)
    for node in nodes:
        for t in [*(s.value for s in node.subscribes), *node.published_topics]:
            if t not in known:
                known.add(t)
                topics.append(Topic(Name(t), comments=("not in the recording",)))
                notes.append(f"graph topic {t} is not in the recording: no rate learned")
    return nodes, hardware, topics


def robot_name(recording: Recording, base: Model | None, options: LearnOptions) -> str:
    if base is not None:
        return base.name.value
    if options.name:
        return options.name
    first = recording.runs[0].path.rstrip("/").rsplit("/", 1)[-1]
    return identifier(re.sub(r"\.bag$", "", first))
