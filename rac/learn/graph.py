"""The computation graph (Definition 9.2) from a YAML file (``racc learn --graph``).

The shape (docs/learning.md shows how ``rosnode info`` / ``ros2 node info`` map to it)::

    nodes:
      /jaguar_node:
        publications: [/pose]          # or: publishers
        subscriptions: [/cmd_vel]      # or: subscribers
        drives: [jaguar]               # optional: hardware the node drives
        host: 10.0.0.2                 # optional: the computer it runs on (racc record)
    hardware:                          # optional
      jaguar: {switchable: true, channel: 1}

A topic entry may keep ``rosnode info``'s type suffix, ``/pose [nav_msgs/Odometry]``, or
``ros2 node info``'s, ``/pose: nav_msgs/msg/Odometry``.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import yaml

from rac.errors import Diagnostic, RacError
from rac.limits import MAX_YAML_BYTES, YamlLimit, compose_yaml, yaml_error_diagnostic

INFRASTRUCTURE_TOPICS = frozenset({"/rosout", "/rosout_agg", "/parameter_events", "/clock"})
# racc's own topics (runtime, board client, repairer): what racc says about the robot.
RACC_TOPICS = frozenset(
    {"/diagnosis", "/observations", "/repair_log", "/board_measurements", "/board_switch"}
)
# Nodes that are not the robot's: racc's own, and ROS's tools (rostopic echo/hz, rosnode,
# rosservice, rosbag record, rqt) and rosout, ROS 1's log aggregator.  Not rviz: an
# operator's visualisation is part of the robot's architecture (tedusar's model has it).
TOOL_NODES = (
    "/racc_*",
    "/rostopic_*",
    "/rosnode_*",
    "/rosservice_*",
    "/record_*",
    "/rosbag_record*",
    "/rqt*",
    "/rosout",
)


@dataclass(frozen=True, slots=True)
class Exclusions:
    """What recording and learning leave out of the robot: racc's own topics and nodes and
    ROS's tool nodes; a topic published only by left-out nodes goes too.  ``include``
    patterns (globs on node or topic names, ``/rostopic_*``, ``/board_measurements``)
    keep what they match."""

    include: tuple[str, ...] = ()

    def _included(self, name: str) -> bool:
        return any(fnmatch.fnmatchcase(name, p) for p in self.include)

    def node(self, name: str) -> bool:
        """Whether the node is the robot's (``/rostopic_25073_…`` is not)."""
        full = "/" + name.lstrip("/")
        if self._included(full) or self._included(full.lstrip("/")):
            return True
        return not any(fnmatch.fnmatchcase(full, p) for p in TOOL_NODES)

    def topic(self, name: str, publishers: Iterable[str] = ()) -> bool:
        """Whether the topic is the robot's: not racc's or ROS's own, and published by a
        robot node (a topic whose publishers are unknown is kept)."""
        if self._included(name):
            return True
        if name in RACC_TOPICS or name in INFRASTRUCTURE_TOPICS:
            return False
        known = list(publishers)
        return not known or any(self.node(n) for n in known)


_NODE_KEYS = {
    "publications": "publications",
    "publishers": "publications",
    "subscriptions": "subscriptions",
    "subscribers": "subscriptions",
    "drives": "drives",
}


@dataclass(frozen=True, slots=True)
class GraphNode:
    name: str
    publications: tuple[str, ...]
    subscriptions: tuple[str, ...]
    drives: tuple[str, ...]
    host: str | None = None


@dataclass(frozen=True, slots=True)
class GraphHardware:
    name: str
    switchable: bool
    channel: int | None


@dataclass(frozen=True, slots=True)
class Graph:
    nodes: tuple[GraphNode, ...]
    hardware: tuple[GraphHardware, ...]


SHAPE_HINT = "see docs/learning.md for the shape"


def _bad(path: str, why: str) -> RacError:
    return RacError([Diagnostic("RAC081", f"{path}: {why}", hint=SHAPE_HINT)])


def _names(value: Any, path: str, where: str) -> tuple[str, ...]:
    if value is None:
        return ()
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise _bad(path, f"{where} must be a list of names")
    # ``/pose [nav_msgs/Odometry]`` as rosnode info prints it, ``* /pose`` as pasted bullets,
    # ``/pose: nav_msgs/msg/Odometry`` as ros2 node info prints it.
    cleaned = (v.strip().removeprefix("*").strip().split(" ")[0].removesuffix(":") for v in value)
    return tuple(v for v in cleaned if v and v not in INFRASTRUCTURE_TOPICS)


def parse_graph(text: str, path: str) -> Graph:
    if len(text) > MAX_YAML_BYTES:
        raise _bad(path, f"the file is {len(text):,} characters long (at most {MAX_YAML_BYTES:,})")
    try:
        compose_yaml(text)  # the limits first (depth, aliases): then loading is safe
        doc = yaml.load(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except YamlLimit as err:
        raise _bad(path, f"line {err.mark.line + 1}: {err.message}") from None
    except yaml.YAMLError as err:
        raise RacError(
            [yaml_error_diagnostic(err, path, "RAC081", hint=SHAPE_HINT)], text
        ) from None
    if not isinstance(doc, dict) or not isinstance(doc.get("nodes"), dict):
        raise _bad(path, "expected a mapping with a 'nodes' mapping")
    unknown = set(doc) - {"nodes", "hardware"}
    if unknown:
        raise _bad(path, f"unknown keys {sorted(unknown)}")
    nodes = []
    for name, body in doc["nodes"].items():
        body = body or {}
        if not isinstance(body, dict):
            raise _bad(path, f"node {name}: expected a mapping")
        extra = set(body) - set(_NODE_KEYS) - {"host"}
        if extra:
            raise _bad(path, f"node {name}: unknown keys {sorted(extra)}")
        lists: dict[str, tuple[str, ...]] = {"publications": (), "subscriptions": (), "drives": ()}
        host = body.get("host")
        if host is not None and not isinstance(host, str):
            raise _bad(path, f"node {name}: host must be a host name or address")
        for key, value in body.items():
            if key != "host":
                lists[_NODE_KEYS[key]] += _names(value, path, f"node {name}: {key}")
        node_name = str(name).removeprefix("/")
        nodes.append(
            GraphNode(
                node_name,
                lists["publications"],
                lists["subscriptions"],
                lists["drives"],
                host.strip() or None if host is not None else None,
            )
        )
    hardware = []
    for name, body in (doc.get("hardware") or {}).items():
        body = body or {}
        if not isinstance(body, dict) or set(body) - {"switchable", "channel"}:
            raise _bad(path, f"hardware {name}: expected {{switchable: BOOL, channel: INT}}")
        channel = body.get("channel")
        if channel is not None and (isinstance(channel, bool) or not isinstance(channel, int)):
            raise _bad(path, f"hardware {name}: channel must be an integer")
        switchable = body.get("switchable", False)
        if not isinstance(switchable, bool):
            raise _bad(path, f"hardware {name}: switchable must be true or false")
        hardware.append(GraphHardware(str(name), switchable, channel))
    return Graph(tuple(nodes), tuple(hardware))
