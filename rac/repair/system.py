"""The repairable system: each component's kind and which node drives which device.

The planner needs to know what a component *is* to repair it: a node is
restarted, a switchable device is power-cycled, other hardware has no repair
action.  From a RAM this is read off the model; a model server file
(``model.yaml``) has only clauses, so the kinds are inferred from them:

- a component ``c`` with a rule whose head is ``on(c)`` is a switchable device;
- a component with a rule whose head is ``running(c)`` is a node;
- a node ``n`` and a device ``d`` in the body of one rule whose head is
  ``ok(t)`` for a topic ``t`` (not a component) means ``n`` drives ``d``;
- any other component is hardware without a repair action.
"""

from __future__ import annotations

from dataclasses import dataclass

from rac.compat import StrEnum
from rac.ir import Model
from rac.logic import NAB, Clause, mangle


class Kind(StrEnum):
    NODE = "node"
    DEVICE = "device"  # switchable hardware
    HARDWARE = "hardware"  # not switchable: no repair action


@dataclass(frozen=True, slots=True)
class RepairSystem:
    """Components (sorted) with their kinds, and the (node, device) drive pairs (sorted)."""

    components: tuple[tuple[str, Kind], ...]
    drives: tuple[tuple[str, str], ...] = ()

    def kind(self, component: str) -> Kind:
        return dict(self.components)[component]

    def of_kind(self, kind: Kind) -> tuple[str, ...]:
        return tuple(c for c, k in self.components if k is kind)

    def names(self) -> tuple[str, ...]:
        return tuple(c for c, _ in self.components)

    def drivers_of(self, device: str) -> tuple[str, ...]:
        return tuple(n for n, d in self.drives if d == device)

    def unrepairable(self, components: tuple[str, ...]) -> tuple[str, ...]:
        """Those of ``components`` no repair action can make good."""
        kinds = dict(self.components)
        return tuple(c for c in components if kinds.get(c, Kind.HARDWARE) is Kind.HARDWARE)


def system_from_model(model: Model, components: tuple[str, ...]) -> RepairSystem:
    """Kinds from the RAM; ``components`` are COMPS (mangled), as the clauses name them."""
    kinds: dict[str, Kind] = {}
    for hw in model.hardware:
        kinds[mangle(hw.name.value)] = Kind.DEVICE if hw.switchable else Kind.HARDWARE
    for node in model.nodes:
        kinds[mangle(node.name.value)] = Kind.NODE
    switchable = {h.name.value for h in model.hardware if h.switchable}
    drives = {
        (mangle(node.name.value), mangle(hw.value))
        for node in model.nodes
        for hw in node.drives
        if hw.value in switchable
    }
    comps = tuple(sorted(components))
    return RepairSystem(
        components=tuple((c, kinds.get(c, Kind.HARDWARE)) for c in comps),
        drives=tuple(sorted((n, d) for n, d in drives if n in comps and d in comps)),
    )


def system_from_clauses(
    clauses: tuple[Clause, ...], components: tuple[str, ...], nab: str = NAB
) -> RepairSystem:
    """Kinds inferred from the clauses of a model server file (see the module text)."""
    comps = set(components)
    devices = {
        c.head.args[0] for c in clauses if c.head.predicate == "on" and len(c.head.args) == 1
    } & comps
    nodes = {
        c.head.args[0] for c in clauses if c.head.predicate == "running" and len(c.head.args) == 1
    } & comps
    nodes -= devices  # a name both on(...) and running(...) is odd; power-cycling covers both
    drives: set[tuple[str, str]] = set()
    for clause in clauses:
        head = clause.head
        if head.predicate != "ok" or len(head.args) != 1 or head.args[0] in comps:
            continue
        assumed = {a.args[0] for a in clause.body if a.predicate == nab and a.args}
        drives |= {(n, d) for n in assumed & nodes for d in assumed & devices}

    def kind(c: str) -> Kind:
        return Kind.DEVICE if c in devices else Kind.NODE if c in nodes else Kind.HARDWARE

    return RepairSystem(
        components=tuple((c, kind(c)) for c in sorted(comps)),
        drives=tuple(sorted(drives)),
    )
