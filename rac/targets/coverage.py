"""What watches each part of the architecture, and what a diagnosis says about it.

The observers model (``rac.passes.observers``) says which observer watches which node,
topic or device; this module turns it around, per drawn thing: a topic's rate observer and
its related pairs, a node's process, its cpu/mem limits and its reports, a device's board
channel and diagnostics.  It also maps an observed atom back to what it is about, so that a
``not ok(pose)`` colours ``/pose`` and ``running(jaguar_node)`` the node.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from rac.fmt import format_mem, format_number
from rac.ir import Model
from rac.logic import Atom, mangle
from rac.passes.observers import ObserverSpec

# Topics every ROS system has, drawn only when an observer watches them: otherwise they tie
# every node to every other one and say nothing about this robot.  Matched on the last part
# of the name, so a namespaced /robot_41/tf is one too.
INFRASTRUCTURE = ("rosout", "rosout_agg", "tf", "tf_static", "diagnostics", "parameter_events")

# The id of a topic in the drawing: ':' is in neither a ROS name nor a hardware name.
TOPIC_ID = "topic:"


def is_infrastructure(topic: str) -> bool:
    return topic.rsplit("/", 1)[-1] in INFRASTRUCTURE


@dataclass(frozen=True, slots=True)
class Health:
    """A diagnosis drawn on the architecture.

    ``diagnoses`` are the minimal diagnoses (component names as the model writes them or as
    atoms mangle them); ``observations`` are the observed atoms with their value.
    """

    title: str
    diagnoses: tuple[tuple[str, ...], ...] = ()
    observations: tuple[tuple[Atom, bool], ...] = ()


@dataclass(frozen=True, slots=True)
class Watch:
    """One observer's view of one drawn thing."""

    kind: str  # NObs, GObs, PObs, DObs, HObs, BiQObs, IObs
    text: str  # what it checks, for the tooltip: "rate 10 Hz ± 1 Hz"
    atoms: tuple[Atom, ...]


def _params(spec: ObserverSpec) -> dict[str, str | int | float]:
    return dict(spec.params)


def _watch_text(spec: ObserverSpec) -> str:
    p = _params(spec)
    if spec.kind == "NObs":
        return "process running"
    if spec.kind == "GObs":
        rate = 1.0 / float(p["delta"])
        band = 1.0 / (float(p["delta"]) + float(p["dev"]))
        return f"rate {format_number(round(rate, 3))} Hz (≥ {format_number(round(band, 3))} Hz)"
    if spec.kind == "PObs":
        value = p["max_val"]
        shown = f"{format_number(float(value))} %" if p["property"] == "cpu" else None
        if shown is None:
            shown = format_mem(int(value))
        return f"{p['property']} ≤ {shown}"
    if spec.kind == "DObs":
        return f"diagnostics of {p['device']} from {p['node']}"
    if spec.kind == "HObs":
        return "board channel power"
    if spec.kind == "BiQObs":
        return f"trend {_side(p, 1)} ~ {_side(p, 2)}"
    return f"interval {_side(p, 1)} ~ {_side(p, 2)} within {format_number(float(p['max_diff']))}"


def _side(p: Mapping[str, str | int | float], k: int) -> str:
    ref = f"{p[f'topic{k}']}.{p[f'field{k}']}"
    return f"I({ref})" if p.get(f"integral{k}") else ref


def watches(model: Model, observers: Iterable[ObserverSpec]) -> dict[str, list[Watch]]:
    """Drawn id (a node's, a device's or ``topic:NAME``) -> the observers watching it."""
    hardware = model.hardware_by_name()
    channels = {h.name.value: h.channel for h in model.hardware if h.switchable}
    by_atom = {mangle(h): h for h in channels}  # an HObs atom's argument -> the device
    out: dict[str, list[Watch]] = {}

    def add(key: str, watch: Watch) -> None:
        out.setdefault(key, []).append(watch)

    for spec in observers:
        p = _params(spec)
        text = _watch_text(spec)
        if spec.kind in ("NObs", "PObs"):
            add(str(p["node"]), Watch(spec.kind, text, spec.atoms))
        elif spec.kind == "GObs":
            add(TOPIC_ID + str(p["topic"]), Watch(spec.kind, text, spec.atoms))
        elif spec.kind == "DObs":
            device = str(p["device"])
            owners = [device] if device in hardware else str(p["node"]).split(",")
            for owner in owners:
                add(owner, Watch(spec.kind, text, spec.atoms))
        elif spec.kind == "HObs":
            for atom in spec.atoms:
                name = by_atom.get(atom.args[0])
                if name is not None:
                    add(name, Watch(spec.kind, f"board channel {channels[name]} power", (atom,)))
        else:  # BiQObs, IObs: both topics of the pair
            for topic in dict.fromkeys((str(p["topic1"]), str(p["topic2"]))):
                add(TOPIC_ID + topic, Watch(spec.kind, text, spec.atoms))
    return out


def component_keys(model: Model) -> dict[str, str]:
    """A component's name as the model writes it and as atoms mangle it -> its drawn id."""
    keys: dict[str, str] = {}
    for name in [*(h.name.value for h in model.hardware), *(n.name.value for n in model.nodes)]:
        keys[mangle(name)] = name
        keys[name] = name
    return keys


@dataclass(frozen=True, slots=True)
class Marks:
    """What the health view colours: drawn ids."""

    faulty: frozenset[str]  # in every minimal diagnosis
    suspect: frozenset[str]  # in some minimal diagnosis only
    bad: frozenset[str]  # an observer of it reads bad
    good: frozenset[str]  # every observer of it that reported reads good


def marks(model: Model, watched: Mapping[str, list[Watch]], health: Health) -> Marks:
    keys = component_keys(model)
    named = [frozenset(keys.get(c, c) for c in d) for d in health.diagnoses]
    faulty = frozenset.intersection(*named) if named else frozenset()
    suspect = frozenset().union(*named) - faulty if named else frozenset()
    value: dict[Atom, bool] = dict(health.observations)
    bad: set[str] = set()
    seen: set[str] = set()
    for key, watch_list in watched.items():
        for watch in watch_list:
            for atom in watch.atoms:
                if atom in value:
                    seen.add(key)
                    if not value[atom]:
                        bad.add(key)
    return Marks(faulty, suspect, frozenset(bad), frozenset(seen - bad))
