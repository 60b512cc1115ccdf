"""What the observer host received and what it cost, measured every period of its sample
loop (``NODE: load`` on ``/diagnostics``)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rac.runtime.status import Row

if TYPE_CHECKING:
    from rac.runtime.host import ObserverHost

# The host is one Python process: past this share of one core it cannot keep up with its
# topics (messages wait in the kernel, then come in clumps, and it starves its own ticks).
BUSY_CPU_PERCENT = 80.0
COST_PERIOD_S = 10.0  # the cost is measured over this long


@dataclass(frozen=True, slots=True)
class HostCost:
    """What the observer host received and what it cost over one period: the whole process
    (every thread: the transport's receiving, the observers, the sample loop), as a share
    of one core and per message received."""

    seconds: float
    messages: int
    cpu_s: float
    starved_s: float  # of the period, how long the host was starved
    path_s: float | None = None  # of cpu_s, the receiving thread's (None: not measured)
    # Topics taken from their subscribers' reports at the period's end (None: the host
    # takes none so), and the messages those reports counted, which it did not receive.
    statistics_topics: int | None = None
    reported: int = 0

    @property
    def rate(self) -> float:
        return self.messages / self.seconds if self.seconds > 0 else 0.0

    @property
    def cpu_percent(self) -> float:
        return 100.0 * self.cpu_s / self.seconds if self.seconds > 0 else 0.0

    @property
    def us_per_message(self) -> float:
        return 1e6 * self.cpu_s / self.messages if self.messages else 0.0

    @property
    def us_per_message_path(self) -> float | None:
        """The receiving thread's CPU per message: client library, observers, bookkeeping."""
        if self.path_s is None or not self.messages:
            return None
        return 1e6 * self.path_s / self.messages

    @property
    def keeping_up(self) -> bool:
        return self.cpu_percent < BUSY_CPU_PERCENT and self.starved_s < 0.5 * self.seconds

    def text(self) -> str:
        path = self.us_per_message_path
        return (
            f"{self.rate:.0f} messages/s, {self.cpu_percent:.1f} % of a core, "
            f"{self.us_per_message:.1f} µs a message"
            + ("" if path is None else f" ({path:.1f} µs receiving and observing)")
            + ("" if self.starved_s <= 0 else f", starved {self.starved_s:.1f} s")
            + (
                ""
                if self.statistics_topics is None
                else f"; {self.statistics_topics} topics from /statistics "
                f"({self.reported / self.seconds if self.seconds > 0 else 0.0:.0f} "
                "messages/s reported, not received)"
            )
        )

    def row(self, node: str) -> Row:
        """``NODE: load`` on ``/diagnostics``: level 0 while the host keeps up, 1 when it
        cannot (its timing verdicts are then held as while starved)."""
        values: tuple[tuple[str, str], ...] = (
            ("messages_per_s", f"{self.rate:.1f}"),
            ("cpu_percent", f"{self.cpu_percent:.1f}"),
            ("us_per_message", f"{self.us_per_message:.2f}"),
            ("starved_s", f"{self.starved_s:.2f}"),
        )
        path = self.us_per_message_path
        if path is not None:
            values += (("us_per_message_path", f"{path:.2f}"),)
        if self.statistics_topics is not None:
            reported = self.reported / self.seconds if self.seconds > 0 else 0.0
            values += (
                ("statistics_topics", str(self.statistics_topics)),
                ("reported_per_s", f"{reported:.1f}"),
            )
        if self.keeping_up:
            return Row(f"{node}: load", 0, self.text(), "", values)
        return Row(f"{node}: load", 1, f"cannot keep up: {self.text()}", "", values)


class CostMeter:
    """Measures :class:`HostCost` every ``period_s`` of the sample loop's ticks."""

    def __init__(
        self,
        host: ObserverHost,
        period_s: float = COST_PERIOD_S,
        cpu: Callable[[], float] = time.process_time,
    ) -> None:
        self.host, self.period_s, self.cpu = host, period_s, cpu
        self.last: HostCost | None = None
        # (time, messages, cpu, the receiving thread's cpu, messages reported)
        self._since: tuple[float, int, float, float | None, int] | None = None
        self._starved = 0.0
        self._starved_at: float | None = None

    def tick(self, now: float) -> HostCost | None:
        """The cost of the period that ended at ``now``, when one did."""
        host = self.host
        if host.starved and self._starved_at is None:
            self._starved_at = now
        elif not host.starved and self._starved_at is not None:
            self._starved += now - self._starved_at
            self._starved_at = None
        path = host.path_cpu() if host.path_cpu is not None else None
        if self._since is None:
            self._since = (now, host.received, self.cpu(), path, host.reported)
            return None
        start, received, cpu, path_before, reported = self._since
        if now - start < self.period_s:
            return None
        if self._starved_at is not None:
            self._starved += now - self._starved_at
            self._starved_at = now
        used = self.cpu()
        on_path = None if path is None or path_before is None else path - path_before
        topics = host.statistics_topics() if host.statistics_topics is not None else None
        cost = HostCost(
            now - start,
            host.received - received,
            used - cpu,
            self._starved,
            on_path,
            topics,
            host.reported - reported,
        )
        self._since = (now, host.received, used, path, host.reported)
        self._starved, self.last = 0.0, cost
        return cost
