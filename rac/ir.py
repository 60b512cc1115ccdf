"""The typed IR of a Robot Architecture Model (RAM, §4.2.1, docs/spec.md).

Frozen, slotted dataclasses with tuples only, so passes cannot mutate what
they are given and models can be hashed and compared.  Every node that came
from source carries a :class:`~rac.errors.Span`; models read from JSON carry
``None``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Protocol

from rac.errors import Span


class _Named(Protocol):
    @property
    def name(self) -> Name: ...


@dataclass(frozen=True, slots=True)
class Name:
    """A name as written at one place in the source (a declaration or a reference)."""

    value: str
    span: Span | None = dataclasses.field(default=None, compare=False)


@dataclass(frozen=True, slots=True)
class Hardware:
    name: Name
    switchable: bool = False
    channel: int | None = None
    comments: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    span: Span | None = dataclasses.field(default=None, compare=False)


@dataclass(frozen=True, slots=True)
class Topic:
    name: Name
    msg_type: str | None = None
    fields: tuple[Name, ...] = ()
    rate_hz: float | None = None
    rate_tolerance_hz: float | None = None
    window_s: float | None = None
    mismatch_threshold: int | None = None
    comments: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    span: Span | None = dataclasses.field(default=None, compare=False)
    # Where the rate (``@ 10 Hz``) and each of its options (``+- 1 Hz``, ``window 2 s``,
    # ``mismatch 3``) are written, for messages about one of them; None from JSON.
    rate_span: Span | None = dataclasses.field(default=None, compare=False)
    tolerance_span: Span | None = dataclasses.field(default=None, compare=False)
    window_span: Span | None = dataclasses.field(default=None, compare=False)
    mismatch_span: Span | None = dataclasses.field(default=None, compare=False)

    @property
    def regular(self) -> bool:
        """A topic with a rate gets a frequency observer (GObs)."""
        return self.rate_hz is not None


@dataclass(frozen=True, slots=True)
class Publication:
    """One output topic of a node and the inputs that affect it (δ_aff)."""

    topic: Name
    affected_by: tuple[Name, ...] = ()


@dataclass(frozen=True, slots=True)
class Limits:
    cpu: float | None = None  # percent of one core
    mem: int | None = None  # bytes
    span: Span | None = dataclasses.field(default=None, compare=False)

    @property
    def declared(self) -> tuple[str, ...]:
        return tuple(p for p, v in (("cpu", self.cpu), ("mem", self.mem)) if v is not None)


@dataclass(frozen=True, slots=True)
class Machine:
    """A computer of the robot (``machine NAME [address ADDR]``): where nodes run, where
    an observer host watches their processes and where they are restarted."""

    name: Name
    address: str | None = None  # host name or IP address, as roslaunch's <machine> takes it
    comments: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    span: Span | None = dataclasses.field(default=None, compare=False)


CONTAINER_RUNTIMES = ("docker", "podman")


@dataclass(frozen=True, slots=True)
class Container:
    """``in container NAME via docker|podman``: the node runs in that container, which is
    restarted to restart the node."""

    name: Name
    runtime: str  # one of CONTAINER_RUNTIMES


@dataclass(frozen=True, slots=True)
class Node:
    name: Name
    drives: tuple[Name, ...] = ()
    subscribes: tuple[Name, ...] = ()
    publishes: tuple[Publication, ...] = ()
    limits: Limits = Limits()
    diagnostics: tuple[Name, ...] = ()
    machine: Name | None = None  # ``on MACHINE``; None: the robot's first machine, or this one
    container: Container | None = None
    comments: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    inner_comments: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    # Comments inside the body, each with the statement it stands above: "subscribes",
    # "pub:TOPIC", "limits", "reports", or "end" (after the last statement).
    body_comments: tuple[tuple[str, str], ...] = dataclasses.field(default=(), compare=False)
    span: Span | None = dataclasses.field(default=None, compare=False)

    @property
    def published_topics(self) -> tuple[str, ...]:
        return tuple(p.topic.value for p in self.publishes)


@dataclass(frozen=True, slots=True)
class FieldRef:
    """``TOPIC.FIELD_PATH``, or ``I(TOPIC.FIELD_PATH)`` for its running integral.

    ROS names hold no dots, so the first dot splits them.  An integrated reference's
    span runs from the ``I`` to the closing parenthesis.
    """

    topic: str
    field: str
    span: Span | None = dataclasses.field(default=None, compare=False)
    integrated: bool = False

    @property
    def path(self) -> str:
        """``TOPIC.FIELD_PATH``, without ``I()``."""
        return f"{self.topic}.{self.field}"

    @property
    def text(self) -> str:
        """The reference as written: ``/pose.yaw`` or ``I(/pose.twist.twist.angular.z)``."""
        return f"I({self.topic}.{self.field})" if self.integrated else f"{self.topic}.{self.field}"

    @staticmethod
    def parse(text: str, span: Span | None = None) -> FieldRef:
        """Read :attr:`text` back: ``TOPIC.FIELD_PATH`` or ``I(TOPIC.FIELD_PATH)``."""
        integrated = text.startswith("I(") and text.endswith(")")
        if integrated:
            text = text[2:-1]
        topic, _, path = text.partition(".")
        return FieldRef(topic, path, span, integrated)


@dataclass(frozen=True, slots=True)
class Related:
    """δ_rel: two fields (either may be integrated) whose qualitative trends match (BiQObs)."""

    a: FieldRef
    b: FieldRef
    comments: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    span: Span | None = dataclasses.field(default=None, compare=False)


@dataclass(frozen=True, slots=True)
class Interval:
    """Two fields whose difference stays within ``max_diff`` (IObs)."""

    a: FieldRef
    b: FieldRef
    max_diff: float
    comments: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    span: Span | None = dataclasses.field(default=None, compare=False)


@dataclass(frozen=True, slots=True)
class Model:
    name: Name
    hardware: tuple[Hardware, ...] = ()
    topics: tuple[Topic, ...] = ()
    nodes: tuple[Node, ...] = ()
    related: tuple[Related, ...] = ()
    intervals: tuple[Interval, ...] = ()
    machines: tuple[Machine, ...] = ()
    comments: tuple[str, ...] = dataclasses.field(
        default=(), compare=False
    )  # before the `robot` header
    trailing_comments: tuple[str, ...] = dataclasses.field(
        default=(), compare=False
    )  # after the last declaration
    path: str = dataclasses.field(default="<model>", compare=False)
    source: str | None = dataclasses.field(default=None, compare=False, repr=False)
    # Derived lookups computed once per model (the passes ask for publishers() often);
    # a cache only, outside comparison and hashing.
    _memo: dict[str, object] = dataclasses.field(
        default_factory=dict, init=False, compare=False, hash=False, repr=False
    )

    def hardware_by_name(self) -> Mapping[str, Hardware]:
        return self._by_name("hardware", self.hardware)

    def topic_by_name(self) -> Mapping[str, Topic]:
        return self._by_name("topics", self.topics)

    def node_by_name(self) -> Mapping[str, Node]:
        return self._by_name("nodes", self.nodes)

    def machine_of(self, node: Node) -> str | None:
        """The machine a node runs on: its ``on``, else the first machine declared (None:
        the robot declares no machine, everything runs on one computer)."""
        if node.machine is not None:
            return node.machine.value
        return self.machines[0].name.value if self.machines else None

    def _by_name(self, kind: str, items: tuple[_Named, ...]) -> Mapping[str, Any]:
        """Declarations by name (the last of a duplicated name), built once per model: the
        passes and emitters ask for them again and again."""
        found = self._memo.get(kind)
        if found is None:  # a dict in the memo: a model is pickled for worker processes
            found = self._memo[kind] = {i.name.value: i for i in items}
        assert isinstance(found, dict)
        return MappingProxyType(found)

    def publishers(self) -> dict[str, tuple[str, ...]]:
        """Topic name -> names of the nodes publishing it, in declaration order."""
        cached = self._memo.get("publishers")
        if cached is None:
            out: dict[str, list[str]] = {}
            for node in self.nodes:
                for topic in node.published_topics:
                    out.setdefault(topic, []).append(node.name.value)
            cached = self._memo["publishers"] = {t: tuple(ns) for t, ns in out.items()}
        assert isinstance(cached, dict)
        return dict(cached)
