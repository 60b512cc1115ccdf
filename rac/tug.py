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

The result is IR, formatted by ``rac.fmt``; the report is a list of notes (RAC106).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import yaml

from rac.errors import Diagnostic, RacError, Severity
from rac.ir import Model, Name, Node, Publication, Topic
from rac.limits import safe_yaml, yaml_error_diagnostic

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
    model: Model
    notes: tuple[str, ...]  # what has no counterpart, or was changed on the way

    def diagnostics(self) -> tuple[Diagnostic, ...]:
        return tuple(Diagnostic("RAC106", n, severity=Severity.NOTE) for n in self.notes)


SHAPE_HINT = (
    "a tug_diagnosis configuration has 'nodes' (name, pub_topic, sub_topic) "
    "and 'observations' (type, topics or nodes)"
)


def _bad(path: str, message: str) -> RacError:
    return RacError([Diagnostic("RAC064", f"{path}: {message}", hint=SHAPE_HINT)])


def _names(value: Any, path: str, where: str, notes: list[str] | None = None) -> list[str]:
    """The names of a list.  Where ``notes`` is given (a node's topics), an empty name is
    none, with a note: real configurations write ``sub_topic: ['']`` for a node that
    subscribes nothing."""
    if value is None:
        return []
    if not isinstance(value, list):
        raise _bad(path, f"{where} must be a list")
    out: list[str] = []
    for item in value:
        if isinstance(item, list):  # timing/velocity entries name topic pairs
            out.extend(_names(item, path, where, notes))
        elif isinstance(item, str) and item:
            out.append(item)
        elif item == "" and notes is not None:
            notes.append(f"{where} holds an empty name, read as none")
        else:
            raise _bad(path, f"{where} holds {item!r}, not a name")
    return out


def _identifier(text: str) -> str:
    cleaned = "".join(c if c.isalnum() or c == "_" else "_" for c in text).strip("_")
    return cleaned if cleaned and cleaned[0].isalpha() else f"robot_{cleaned or 'imported'}"


def import_tug(text: str, path: str, robot: str, default_rate: float = DEFAULT_RATE_HZ) -> Imported:
    """A tug_diagnosis configuration as a RAM model, in its phases: the document, its nodes,
    its observations, then the topic declarations; ``notes`` say what had no counterpart."""
    doc = _document(text, path)
    notes: list[str] = []
    unknown_keys = sorted(set(doc) - {"nodes", "observations"})
    if unknown_keys:
        notes.append(f"top-level keys without a counterpart, ignored: {', '.join(unknown_keys)}")
    # every topic a node or an observation names, in the order first named
    topic_order: dict[str, None] = {}
    nodes = [_node(k, entry, path, topic_order, notes) for k, entry in enumerate(doc["nodes"])]
    rated = _observations(doc.get("observations"), path, nodes, topic_order, notes)
    decls = _topic_declarations(topic_order, rated, default_rate)
    header = (
        f"Imported from the tug_diagnosis configuration {path} by `racc import tug`.",
        "Every published topic depends on all of its node's subscriptions, as tug_diagnosis "
        "models a node.",
    )
    model = Model(Name(_identifier(robot)), (), tuple(decls), tuple(nodes), comments=header)
    return Imported(model, tuple(notes))


def _document(text: str, path: str) -> dict[str, Any]:
    try:
        doc = safe_yaml(text, path)
    except yaml.YAMLError as err:
        raise RacError(
            [yaml_error_diagnostic(err, path, "RAC064", hint=SHAPE_HINT)], text
        ) from None
    if not isinstance(doc, dict) or not isinstance(doc.get("nodes"), list):
        raise _bad(path, "no 'nodes' list")
    return doc


def _node(k: int, entry: Any, path: str, topic_order: dict[str, None], notes: list[str]) -> Node:
    """``nodes[k]``: every published topic depends on all of the node's other inputs."""
    if not isinstance(entry, dict) or not isinstance(entry.get("name"), str):
        raise _bad(path, f"nodes[{k}] has no name")
    name = entry["name"]
    pubs = _names(entry.get("pub_topic"), path, f"node {name}: pub_topic", notes)
    subs = _names(entry.get("sub_topic"), path, f"node {name}: sub_topic", notes)
    pubs, subs = list(dict.fromkeys(pubs)), list(dict.fromkeys(subs))
    extra = sorted(set(entry) - {"name", "pub_topic", "sub_topic"})
    if extra:
        notes.append(f"node {name}: keys without a counterpart, ignored: {', '.join(extra)}")
    topic_order.update(dict.fromkeys([*subs, *pubs]))
    publications = []
    for t in pubs:
        inputs = [s for s in subs if s != t]
        if t in subs:
            notes.append(
                f"node {name} subscribes and publishes {t}: its {t} cannot depend on "
                f"itself (Proposition 4.1), so it depends on its other inputs only"
            )
        publications.append(Publication(Name(t), tuple(Name(i) for i in inputs)))
    return Node(
        Name(name.removeprefix("/")),
        subscribes=tuple(Name(s) for s in subs),
        publishes=tuple(publications),
    )


def _observations(
    observations: Any,
    path: str,
    nodes: list[Node],
    topic_order: dict[str, None],
    notes: list[str],
) -> set[str]:
    """The topics an ``hz`` observation watches; every other kind becomes a note."""
    rated: set[str] = set()
    observations = observations or []
    if not isinstance(observations, list):
        raise _bad(path, "'observations' must be a list")
    known_nodes = {n.name.value for n in nodes}
    for k, obs in enumerate(observations):
        if not isinstance(obs, dict) or not isinstance(obs.get("type"), str):
            raise _bad(path, f"observations[{k}] has no type")
        kind = obs["type"]
        topics = _names(obs.get("topics"), path, f"observations[{k}].topics")
        obs_nodes = _names(obs.get("nodes"), path, f"observations[{k}].nodes")
        if kind == "hz":
            for t in topics:
                if t not in topic_order:
                    notes.append(f"hz on {t}: no node publishes or subscribes it; declared")
                    topic_order[t] = None
                rated.add(t)
        elif kind == "activated":
            missing = [n for n in obs_nodes if n.removeprefix("/") not in known_nodes]
            if missing:
                notes.append(f"activated names unknown nodes, ignored: {', '.join(missing)}")
        elif kind == "resources":
            names = ", ".join(obs_nodes) or "(none named)"
            notes.append(
                f"resources on {names}: a PObs needs limits (`limits cpu N %, mem N MB`) the "
                "configuration does not give; add them, or learn them (racc learn)"
            )
        else:
            need = MISSING.get(kind, f"an observer of type '{kind}'")
            what = ", ".join(topics or obs_nodes) or "(nothing named)"
            notes.append(f"{kind} on {what}: no counterpart; needs {need}")
    return rated


def _topic_declarations(
    topic_order: dict[str, None], rated: set[str], default_rate: float
) -> list[Topic]:
    decls = []
    for t in topic_order:
        if t in rated:
            comment = (
                f"hz observed in the tug configuration; rate {default_rate:g} Hz is a "
                "placeholder: take it from tug_observers' configuration or racc learn",
            )
            decls.append(Topic(Name(t), rate_hz=default_rate, comments=comment))
        else:
            decls.append(Topic(Name(t)))
    return decls


def notes_as_comments(notes: Iterable[str]) -> tuple[str, ...]:
    return tuple(f"import: {n}" for n in notes)
