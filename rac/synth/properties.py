"""The properties CSV written beside a synthetic recording: ``time,node,cpu,mem``.

Each node uses a steady share of its model limits (40 % of its CPU limit, half its memory
limit; 5 % and 50 MB without limits) with noise, sampled at 2 Hz.  ``cpu`` and ``mem``
faults raise them (CPU to twice the limit and at least 30 %, memory doubled and at least
1.5 times the limit, so that a model's own limit sees it); a crashed
node has no samples after its crash.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rac.ir import Model
from rac.synth.faults import Fault

SAMPLE_HZ = 2.0
DEFAULT_CPU = 5.0
DEFAULT_MEM = 50_000_000
HEADER = "time,node,cpu,mem"


def properties_csv(
    model: Model, duration: float, faults: Sequence[Fault], rng: np.random.Generator
) -> str:
    times = np.arange(0.0, duration, 1.0 / SAMPLE_HZ)
    rows: list[tuple[float, str, float, int]] = []
    for node in sorted(model.nodes, key=lambda n: n.name.value):
        name = node.name.value
        cpu_base = 0.4 * node.limits.cpu if node.limits.cpu is not None else DEFAULT_CPU
        mem_base = 0.5 * node.limits.mem if node.limits.mem is not None else DEFAULT_MEM
        cpu = np.abs(cpu_base + rng.normal(0.0, 0.08 * cpu_base, times.size))
        mem = mem_base * (1.0 + rng.normal(0.0, 0.01, times.size))
        alive = np.ones(times.size, dtype=bool)
        for f in faults:
            if f.target != name:
                continue
            during = (times >= f.start) & (times < f.end)
            if f.kind == "cpu":
                limit = node.limits.cpu if node.limits.cpu is not None else DEFAULT_CPU
                cpu[during] = max(30.0, 2 * limit) + rng.normal(0.0, 1.0, int(during.sum()))
            elif f.kind == "mem":
                floor = 1.5 * node.limits.mem if node.limits.mem is not None else 0.0
                mem[during] = np.maximum(mem[during] * 2.0, floor)
            elif f.kind == "crash":
                alive &= ~during
        for t, c, m, a in zip(times, cpu, mem, alive, strict=True):
            if a:
                rows.append((float(t), name, float(c), int(m)))
    rows.sort(key=lambda r: (r[0], r[1]))
    lines = [HEADER, *(f"{t:.3f},{n},{c:.3f},{m}" for t, n, c, m in rows)]
    return "\n".join(lines) + "\n"
