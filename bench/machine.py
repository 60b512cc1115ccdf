"""What a size ratio measured on this machine is bounded by: its caches and the working set.

A 1k/10k time ratio compares two runs that meet memory differently.  The work of both is
linear, but a working set that fits the last-level cache is served from it, and one that
does not goes to main memory for most of its objects, several times slower per access.  The
benches print both figures beside their ratios so that a reader can tell the algorithm's
scaling from the machine's.
"""

from __future__ import annotations

import gc
import tracemalloc
from collections.abc import Callable
from pathlib import Path

CACHES = Path("/sys/devices/system/cpu/cpu0/cache")


def last_level_cache() -> int | None:
    """The size in bytes of the largest cache of CPU 0 (Linux sysfs); None when unknown."""
    sizes = []
    for index in sorted(CACHES.glob("index*")):
        try:
            text = (index / "size").read_text(encoding="ascii").strip()
        except OSError:
            continue
        units = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}
        if text[-1:] in units and text[:-1].isdigit():
            sizes.append(int(text[:-1]) * units[text[-1]])
        elif text.isdigit():
            sizes.append(int(text))
    return max(sizes, default=None)


def working_set(action: Callable[[], object]) -> int:
    """The peak of the memory Python allocates while ``action`` runs, result included
    (tracemalloc: an untimed run of its own, as tracing slows every allocation)."""
    gc.collect()
    tracemalloc.start()
    try:
        result = action()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    del result
    return peak


def mib(size: int | None) -> str:
    return "unknown" if size is None else f"{size / (1 << 20):.1f} MiB"


def fits_note(sets: dict[int, int], cache: int | None) -> str:
    """One line: each size's working set against the last-level cache."""

    def verdict(peak: int) -> str:
        if cache is None:
            return ""
        return " (fits)" if peak <= cache else " (exceeds it)"

    shown = ", ".join(f"{size}: {mib(peak)}{verdict(peak)}" for size, peak in sorted(sets.items()))
    return f"working sets against the {mib(cache)} last-level cache: {shown}"
