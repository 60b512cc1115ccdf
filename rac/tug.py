"""Import a tug_diagnosis configuration (the dissertation's successor system) as a model.

Its YAML has ``nodes`` (each ``name``, ``pub_topic``, ``sub_topic``) and ``observations``
(each a ``type`` with ``topics`` or ``nodes``).  The mapping:

- a node → ``node`` with its subscriptions; every topic it publishes depends on all of its
  subscriptions (tug_diagnosis's own model of a node), hence ``publishes T from …``.  A node
  that subscribes to a topic it also publishes (``/tf``) cannot make that output depend on
  itself (Proposition 4.1): the dependency is dropped and reported;
- every topic named → ``topic``; the configuration holds no message types or fields;
- ``hz`` → a rate, so a frequency observer (GObs).  The rates live in tug_observers' own
  configuration, not here: ``default_rate`` is written and the topic says so in a comment;
- ``activated`` → nothing to add: every node has a node observer (NObs);
- ``resources`` → ``limits`` need values the configuration does not give: reported;
- ``timeout``, ``timestamp``, ``timing``, ``velocity``, ``movement``, ``scores`` and any other
  type have no counterpart in the language: reported, with the feature they would need.

The result is IR, formatted by ``rac.fmt``; the report is a list of notes (RAC106).  Every
name in the IR carries its span in the configuration, so that an error of the model (an
invalid ROS name, RAC028) points at the configuration's line.  White space around a name
(``'/tf '``, as real configurations have) is trimmed with a warning at its line (RAC180).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import yaml

from rac.errors import Diagnostic, RacError, Severity, Span
from rac.ir import Model, Name, Node, Publication, Topic
from rac.limits import composed_yaml, safe_yaml, yaml_error_diagnostic

DEFAULT_RATE_HZ = 10.0

# What each observation type would need in the language (None: it has a counterpart).
MISSING = {
    "timeout": "a timeout observer (the longest gap between two messages), one-sided unlike "
    "a GObs's rate band",
    "timestamp": "a timestamp observer (the age of a message's header stamp)",
    "timing": "a timing observer (the delay from one topic's message to another's)",
    "velocity": "a velocity observer comparing commanded and measured motion (field names "
    "and a tolerance; `relate` compares trends of declared fields only)",
    "movement": "a movement observer (whether the robot moves as commanded)",
    "scores": "a score observer (a quality value published by a node)",
}


@dataclass(frozen=True, slots=True)
class Imported:
    """The model, whose names carry spans into the configuration (so that an error of the
    model points at the configuration's line), and what was noted or corrected."""

    model: Model
    notes: tuple[str, ...]  # what has no counterpart, or was changed on the way
    warnings: tuple[Diagnostic, ...] = ()  # slips corrected (RAC180), located
    source: str | None = None  # the configuration's text, for the source lines

    def diagnostics(self) -> tuple[Diagnostic, ...]:
        notes = tuple(Diagnostic("RAC106", n, severity=Severity.NOTE) for n in self.notes)
        return (*self.warnings, *notes)


SHAPE_HINT = (
    "a tug_diagnosis configuration has 'nodes' (name, pub_topic, sub_topic) "
    "and 'observations' (type, topics or nodes)"
)


def _bad(path: str, message: str, span: Span | None = None) -> RacError:
    return RacError([Diagnostic("RAC064", f"{path}: {message}", span, hint=SHAPE_HINT)])


Where = tuple[str | int, ...]  # a value's place in the document: ("nodes", 3, "pub_topic", 1)


class _Config:
    """One configuration being read: its path, where each value of the document is, and
    the slips corrected on the way (RAC180)."""

    def __init__(self, path: str, positions: dict[Where, Span]) -> None:
        self.path = path
        self.positions = positions
        self.warnings: list[Diagnostic] = []

    def span(self, where: Where) -> Span | None:
        return self.positions.get(where)

    def bad(self, message: str, where: Where) -> RacError:
        return _bad(self.path, message, self.span(where))

    def names(
        self, value: Any, where: Where, what: str, notes: list[str] | None = None
    ) -> list[Name]:
        """The names of a list, each with its span in the configuration.  Where ``notes``
        is given (a node's topics), an empty name is none, with a note: real configurations
        write ``sub_topic: ['']`` for a node that subscribes nothing.  White space around a
        name (``'/tf '``) is no part of it: trimmed, with a warning at its line (RAC180)."""
        if value is None:
            return []
        if not isinstance(value, list):
            raise self.bad(f"{what} must be a list", where)
        out: list[Name] = []
        for k, item in enumerate(value):
            at = (*where, k)
            if isinstance(item, list):  # timing/velocity entries name topic pairs
                out.extend(self.names(item, at, what, notes))
            elif isinstance(item, str) and item.strip():
                out.append(Name(self.trimmed(item, at, what), self.span(at)))
            elif isinstance(item, str) and notes is not None:
                shown = "an empty name" if item == "" else f"{item!r}, no name"
                notes.append(f"{what} holds {shown}, read as none")
            else:
                raise self.bad(f"{what} holds {item!r}, not a name", at)
        return out

    def trimmed(self, text: str, where: Where, what: str) -> str:
        name = text.strip()
        if name != text:
            message = (
                f"{what} holds {text!r}: the white space around the name is no part of it, "
                f"read as '{name}'"
            )
            hint = f"write '{name}' in the configuration"
            diagnostic = Diagnostic(
                "RAC180", message, self.span(where), severity=Severity.WARNING, hint=hint
            )
            self.warnings.append(diagnostic)
        return name


def _positions(node: yaml.Node | None, path: str) -> dict[Where, Span]:
    """Where each value of a composed YAML document is (1-based, as editors count)."""
    found: dict[Where, Span] = {}

    def visit(item: yaml.Node, where: Where) -> None:
        start, end = item.start_mark, item.end_mark
        last = end.column + 1 if end.line == start.line else start.column + 2
        found[where] = Span(path, start.line + 1, start.column + 1, start.line + 1, last)
        if isinstance(item, yaml.SequenceNode):
            for k, child in enumerate(item.value):
                visit(child, (*where, k))
        elif isinstance(item, yaml.MappingNode):
            for key, child in item.value:
                if isinstance(key, yaml.ScalarNode):
                    visit(child, (*where, key.value))

    if node is not None:
        visit(node, ())
    return found


def _identifier(text: str) -> str:
    cleaned = "".join(c if c.isalnum() or c == "_" else "_" for c in text).strip("_")
    return cleaned if cleaned and cleaned[0].isalpha() else f"robot_{cleaned or 'imported'}"


def import_tug(text: str, path: str, robot: str, default_rate: float = DEFAULT_RATE_HZ) -> Imported:
    """A tug_diagnosis configuration as a RAM model, in its phases: the document, its nodes,
    its observations, then the topic declarations; ``notes`` say what had no counterpart."""
    doc, config = _document(text, path)
    try:
        return _import(doc, config, robot, default_rate, text)
    except RacError as err:
        raise RacError(err.diagnostics, text) from None


def _import(
    doc: dict[str, Any], config: _Config, robot: str, default_rate: float, text: str
) -> Imported:
    notes: list[str] = []
    unknown_keys = sorted(set(doc) - {"nodes", "observations"})
    if unknown_keys:
        notes.append(f"top-level keys without a counterpart, ignored: {', '.join(unknown_keys)}")
    # every topic a node or an observation names, in the order first named, with its span
    topic_order: dict[str, Name] = {}
    nodes = [_node(k, entry, config, topic_order, notes) for k, entry in enumerate(doc["nodes"])]
    rated = _observations(doc.get("observations"), config, nodes, topic_order, notes)
    decls = _topic_declarations(topic_order, rated, default_rate)
    header = (
        f"Imported from the tug_diagnosis configuration {config.path} by `racc import tug`.",
        "Every published topic depends on all of its node's subscriptions, as tug_diagnosis "
        "models a node.",
    )
    model = Model(Name(_identifier(robot)), (), tuple(decls), tuple(nodes), comments=header)
    return Imported(model, tuple(notes), tuple(config.warnings), text)


def _document(text: str, path: str) -> tuple[dict[str, Any], _Config]:
    try:
        doc = safe_yaml(text, path)
    except yaml.YAMLError as err:
        raise RacError(
            [yaml_error_diagnostic(err, path, "RAC064", hint=SHAPE_HINT)], text
        ) from None
    positions: dict[Where, Span] = {}
    with contextlib.suppress(yaml.YAMLError):  # safe_yaml read it: so does the composer
        positions = _positions(composed_yaml(text, path), path)
    if not isinstance(doc, dict) or not isinstance(doc.get("nodes"), list):
        message = f"{path}: no 'nodes' list"
        raise RacError([Diagnostic("RAC064", message, positions.get(()), hint=SHAPE_HINT)], text)
    return doc, _Config(path, positions)


def _node(
    k: int, entry: Any, config: _Config, topic_order: dict[str, Name], notes: list[str]
) -> Node:
    """``nodes[k]``: every published topic depends on all of the node's other inputs."""
    at: Where = ("nodes", k)
    if not isinstance(entry, dict) or not isinstance(entry.get("name"), str):
        raise config.bad(f"nodes[{k}] has no name", at)
    name = config.trimmed(entry["name"], (*at, "name"), f"nodes[{k}].name")
    pubs = config.names(
        entry.get("pub_topic"), (*at, "pub_topic"), f"node {name}: pub_topic", notes
    )
    subs = config.names(
        entry.get("sub_topic"), (*at, "sub_topic"), f"node {name}: sub_topic", notes
    )
    pubs, subs = _first_of_each(pubs), _first_of_each(subs)
    extra = sorted(set(entry) - {"name", "pub_topic", "sub_topic"})
    if extra:
        notes.append(f"node {name}: keys without a counterpart, ignored: {', '.join(extra)}")
    for t in [*subs, *pubs]:
        topic_order.setdefault(t.value, t)
    publications = []
    for t in pubs:
        inputs = tuple(s for s in subs if s.value != t.value)
        if len(inputs) < len(subs):
            notes.append(
                f"node {name} subscribes and publishes {t.value}: its {t.value} cannot depend "
                f"on itself (Proposition 4.1), so it depends on its other inputs only"
            )
        publications.append(Publication(t, inputs))
    return Node(
        Name(name.removeprefix("/"), config.span((*at, "name"))),
        subscribes=tuple(subs),
        publishes=tuple(publications),
    )


def _first_of_each(names: list[Name]) -> list[Name]:
    """Each name once, where it is first written."""
    seen: dict[str, Name] = {}
    for n in names:
        seen.setdefault(n.value, n)
    return list(seen.values())


def _observations(
    observations: Any,
    config: _Config,
    nodes: list[Node],
    topic_order: dict[str, Name],
    notes: list[str],
) -> set[str]:
    """The topics an ``hz`` observation watches; every other kind becomes a note."""
    rated: set[str] = set()
    observations = observations or []
    if not isinstance(observations, list):
        raise config.bad("'observations' must be a list", ("observations",))
    known_nodes = {n.name.value for n in nodes}
    for k, obs in enumerate(observations):
        at: Where = ("observations", k)
        if not isinstance(obs, dict) or not isinstance(obs.get("type"), str):
            raise config.bad(f"observations[{k}] has no type", at)
        kind = config.trimmed(obs["type"], (*at, "type"), f"observations[{k}].type")
        topics = config.names(obs.get("topics"), (*at, "topics"), f"observations[{k}].topics")
        obs_nodes = config.names(obs.get("nodes"), (*at, "nodes"), f"observations[{k}].nodes")
        if kind == "hz":
            for t in topics:
                if t.value not in topic_order:
                    notes.append(f"hz on {t.value}: no node publishes or subscribes it; declared")
                    topic_order[t.value] = t
                rated.add(t.value)
        elif kind == "activated":
            missing = [n.value for n in obs_nodes if n.value.removeprefix("/") not in known_nodes]
            if missing:
                notes.append(f"activated names unknown nodes, ignored: {', '.join(missing)}")
        elif kind == "resources":
            names = ", ".join(n.value for n in obs_nodes) or "(none named)"
            notes.append(
                f"resources on {names}: a PObs needs limits (`limits cpu N %, mem N MB`) the "
                "configuration does not give; add them, or learn them (racc learn)"
            )
        else:
            need = MISSING.get(kind, f"an observer of type '{kind}'")
            what = ", ".join(n.value for n in topics or obs_nodes) or "(nothing named)"
            notes.append(f"{kind} on {what}: no counterpart; needs {need}")
    return rated


def _topic_declarations(
    topic_order: dict[str, Name], rated: set[str], default_rate: float
) -> list[Topic]:
    decls = []
    for t, name in topic_order.items():
        if t in rated:
            comment = (
                f"hz observed in the tug configuration; rate {default_rate:g} Hz is a "
                "placeholder: take it from tug_observers' configuration or racc learn",
            )
            decls.append(Topic(name, rate_hz=default_rate, comments=comment))
        else:
            decls.append(Topic(name))
    return decls


def notes_as_comments(notes: Iterable[str]) -> tuple[str, ...]:
    return tuple(f"import: {n}" for n in notes)
