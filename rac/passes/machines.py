"""Which machine runs each observer (issue 28): a robot with several computers has one
observer host per machine, and ``racc compile`` writes into ``observers.yaml`` where each
observer runs (a ``machine`` parameter) and, for a node in a container, how to restart it
(a ``container`` parameter on its NObs, ``docker:NAME`` or ``podman:NAME``).

A node's NObs and PObs run on the node's machine: they watch its process.  A regular
topic's GObs runs on the machine of its publishers when they share one (its messages are
counted where they are sent), else on the first machine; the other observers read topics
that any machine sees and run on the first machine.  A model without machines gets no
``machine`` parameter: one observer host runs everything, as before.
"""

from __future__ import annotations

from collections.abc import Iterable

from rac.ir import Model
from rac.passes.observers import ObserverSpec, ParamValue

MACHINE_PARAM = "machine"
CONTAINER_PARAM = "container"


def _node(spec: ObserverSpec) -> str | None:
    value = dict(spec.params).get("node")
    return str(value).strip().lstrip("/") if value is not None else None


def place_observers(model: Model, specs: Iterable[ObserverSpec]) -> tuple[ObserverSpec, ...]:
    """``specs`` with their ``machine`` (and a contained node's NObs its ``container``)."""
    specs = tuple(specs)
    containers = {
        n.name.value.strip("/"): f"{n.container.runtime}:{n.container.name.value}"
        for n in model.nodes
        if n.container is not None
    }
    if not model.machines and not containers:
        return specs
    nodes = {n.name.value.strip("/"): n for n in model.nodes}
    main = model.machines[0].name.value if model.machines else None
    publishers = model.publishers()
    out = []
    for spec in specs:
        extra: list[tuple[str, ParamValue]] = []
        node = _node(spec) if spec.kind in ("NObs", "PObs") else None
        where = main
        if node is not None and node in nodes:
            where = model.machine_of(nodes[node])
        elif spec.kind == "GObs":
            topic = str(dict(spec.params).get("topic", ""))
            machines = {model.machine_of(nodes[p.strip("/")]) for p in publishers.get(topic, ())}
            where = machines.pop() if len(machines) == 1 else main
        if where is not None:
            extra.append((MACHINE_PARAM, where))
        if spec.kind == "NObs" and node in containers:
            extra.append((CONTAINER_PARAM, containers[node]))
        out.append(ObserverSpec(spec.kind, spec.name, (*spec.params, *extra), spec.atoms))
    return tuple(out)


ROBOT_WIDE = ("HObs", "DObs", "BiQObs", "IObs")  # always on the first machine


def machines_of(specs: Iterable[ObserverSpec]) -> tuple[str, ...]:
    """The machines observers run on: the machine of the robot-wide observers first (the
    model's first machine), then in the order of the specs."""
    specs = tuple(specs)
    wide = [s for s in specs if s.kind in ROBOT_WIDE]
    return tuple(dict.fromkeys(m for s in (*wide, *specs) if (m := spec_machine(s)) is not None))


def spec_machine(spec: ObserverSpec) -> str | None:
    value = dict(spec.params).get(MACHINE_PARAM)
    return str(value) if value is not None else None


def on_machine(specs: Iterable[ObserverSpec], machine: str | None) -> tuple[ObserverSpec, ...]:
    """The observers the host of ``machine`` runs (None: every observer, one host)."""
    if machine is None:
        return tuple(specs)
    return tuple(s for s in specs if spec_machine(s) in (machine, None))


def node_placements(specs: Iterable[ObserverSpec]) -> dict[str, tuple[str | None, str | None]]:
    """Node -> (its machine, its container as ``runtime:NAME``), from the NObs of
    ``observers.yaml``."""
    out: dict[str, tuple[str | None, str | None]] = {}
    for spec in specs:
        node = _node(spec)
        if spec.kind == "NObs" and node is not None:
            container = dict(spec.params).get(CONTAINER_PARAM)
            out[node] = (spec_machine(spec), str(container) if container is not None else None)
    return out
