"""Property observers' limits (Algorithm 15, lines 11-14), with floors."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

from rac.ir import Limits, Node
from rac.learn.properties import PropertyStats

# Limits' floors: an idle node's samples (0.01 % cpu, a flat memory use) would give a limit
# that any ordinary burst of work crosses.
CPU_FLOOR = 5.0  # % of one core
MEM_MARGIN = 1.2  # times the largest memory sample


def learned_limits(node: Node, stats: Sequence[PropertyStats], sigmas: float) -> Node:
    mine = {s.prop: s for s in stats if s.node == node.name.value}
    if not mine:
        return node
    cpu, mem = node.limits.cpu, node.limits.mem
    notes = []
    if "cpu" in mine:
        s = mine["cpu"]
        cpu = max(CPU_FLOOR, math.ceil(s.limit(sigmas) * 100) / 100)
        notes.append(f"cpu mean {s.mean:.3g} % σ {s.stddev:.3g} max {s.maximum:.3g} -> {cpu:g} %")
    if "mem" in mine:
        s = mine["mem"]
        mem = max(1000, math.ceil(max(s.limit(sigmas), MEM_MARGIN * s.maximum) / 1000) * 1000)
        notes.append(
            f"mem mean {s.mean / 1e6:.4g} MB σ {s.stddev / 1e6:.3g} MB max {s.maximum / 1e6:.4g} MB"
            f" -> {mem / 1e6:g} MB"
        )
    samples = max(s.samples for s in mine.values())
    comment = (
        f"learned limits from {samples} samples (mean + {sigmas:g}σ, at least the max; cpu at "
        f"least {CPU_FLOOR:g} %, mem at least {MEM_MARGIN:g} × the max): "
    )
    comment += "; ".join(notes)
    span = node.limits.span
    return replace(node, limits=Limits(cpu, mem, span), comments=(*node.comments, comment))
