"""What ``racc watch`` prints: the runtime's status arrays as terminal lines, only what
changed, each with the time it was received.

``/observations`` arrive whole (at least once a second); a line is printed per literal
that flipped, and once, at first, the count of literals and those that do not hold.
``/diagnosis`` prints a line when the set of diagnoses changes; ``/repair_log`` a line
per entry (it is a log already).  Transport-free: the ROS nodes hand rows in.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence

from rac.runtime.bus import Bus
from rac.runtime.status import DIAGNOSIS, NO_DIAGNOSIS, OBSERVATIONS, REPAIR_LOG, Row

LEVELS = {0: "ok", 1: "warn", 2: "ERROR", 3: "stale"}


def clock(t: float) -> str:
    """``HH:MM:SS.mmm``, local time: the form the nodes' logs can be matched against."""
    return time.strftime("%H:%M:%S", time.localtime(t)) + f".{int(t * 1000) % 1000:03d}"


class Watch:
    """The last arrays seen, and the lines that say how each new one differs."""

    def __init__(self) -> None:
        self.literals: dict[str, str] | None = None  # atom -> literal
        self.diagnoses: tuple[str, ...] | None = None

    def observations(self, rows: Sequence[Row], t: float) -> list[str]:
        # An array holds the rows that changed, or every row: merged into what was seen.
        now = {**(self.literals or {}), **{r.name: r.message for r in rows}}
        stamp = f"{clock(t)} observations"
        if self.literals is None:
            self.literals = now
            failing = sorted(m for r in rows if r.level for m in [r.message])
            head = f"{stamp}  {len(now)} literals, {len(failing)} not holding"
            return [head + (": " + ", ".join(failing) if failing else "")]
        lines = []
        for atom in sorted(now.keys() | self.literals.keys()):
            before, after = self.literals.get(atom), now.get(atom)
            if before == after:
                continue
            if after is None:
                lines.append(f"{stamp}  {before} -> (no longer reported)")
            elif before is None:
                lines.append(f"{stamp}  {after} (new)")
            else:
                lines.append(f"{stamp}  {before} -> {after}")
        self.literals = now
        return lines

    def diagnosis(self, rows: Sequence[Row], t: float) -> list[str]:
        now = tuple(r.message if r.name != NO_DIAGNOSIS else NO_DIAGNOSIS for r in rows)
        if now == self.diagnoses:
            return []
        self.diagnoses = now
        stamp = f"{clock(t)} diagnosis   "
        if not now:
            return [f"{stamp}  no fault"]
        if now == (NO_DIAGNOSIS,):
            return [f"{stamp}  no diagnosis explains the observations"]
        shown = " | ".join("{" + d + "}" for d in now)
        return [f"{stamp}  {len(now)} diagnos{'is' if len(now) == 1 else 'es'}: {shown}"]

    def repair(self, rows: Sequence[Row], t: float) -> list[str]:
        lines = []
        for r in rows:
            target = f" {r.hardware_id}" if r.hardware_id else ""
            level = LEVELS.get(r.level, str(r.level))
            lines.append(f"{clock(t)} repair       {level:5s} {r.name}{target}: {r.message}")
        return lines


def run_watch(
    bus: Bus, topics: Sequence[str], duration: float | None, out: Callable[[str], None]
) -> None:
    """Print what changes on ``topics`` until the bus stops or ``duration`` passes."""
    watch = Watch()
    lock = threading.Lock()
    handlers = {
        OBSERVATIONS: watch.observations,
        DIAGNOSIS: watch.diagnosis,
        REPAIR_LOG: watch.repair,
    }

    def receiver(topic: str) -> Callable[[list[Row]], None]:
        def receive(rows: list[Row]) -> None:
            with lock:
                for line in handlers[topic](rows, time.time()):
                    out(line)

        return receive

    for topic in topics:
        bus.on_rows(topic, receiver(topic), 50, latched=True)
    end = None if duration is None else time.time() + duration
    while bus.ok and (end is None or time.time() < end):
        time.sleep(0.1)
