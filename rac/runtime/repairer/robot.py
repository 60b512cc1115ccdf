"""The robot as a whole, as the observations show its nodes: which nodes were heard of,
which run, which were ever seen running (the bring-up grace), which stopped and when, and
from that whether the robot is shutting down (many nodes stopping together, or its
middleware gone), in which case the repairer acts on nothing.
"""

from __future__ import annotations

from collections.abc import Collection

from rac.runtime.repairer.settings import Settings


class RobotWatch:
    def __init__(self, settings: Settings, now: float) -> None:
        self.settings = settings
        self.begun = now  # when the repairer started
        self.back_at = now  # when the robot last came back
        self.heard: dict[str, float] = {}  # node -> when Θ first said anything of it
        self.running: dict[str, bool] = {}
        self.seen_running: set[str] = set()
        self.went_down: dict[str, float] = {}  # node -> when it stopped (was running)
        self.middleware_down = ""  # why the transport says the robot's middleware is gone
        self.down = ""  # why the robot is shutting down ("" while it runs)

    def observe(self, node: str, running: bool, now: float) -> None:
        self.heard.setdefault(node, now)
        was = self.running.get(node)
        self.running[node] = running
        if running:
            self.seen_running.add(node)
            self.went_down.pop(node, None)
        elif was:
            self.went_down[node] = now

    def stopping_together(self, ours: Collection[str]) -> list[str]:
        """The nodes that stopped last, each within shutdown_window_s of the one before
        (not ``ours``, those the plan under way stopped itself)."""
        down = sorted(
            (t, n)
            for n, t in self.went_down.items()
            if self.running.get(n) is False and n not in ours
        )
        group: list[tuple[float, str]] = []
        for t, n in down:
            if group and t - group[-1][0] > self.settings.shutdown_window_s:
                group = []
            group.append((t, n))
        return [n for _, n in group]

    def _nodes_down_reason(self, ours: Collection[str]) -> str:
        together = self.stopping_together(ours)
        known = len(self.running)
        if len(together) >= 2 and len(together) > self.settings.shutdown_fraction * known:
            return f"{len(together)} of {known} nodes stopped together"
        return ""

    def shutdown_reason(self, ours: Collection[str]) -> str:
        """Why the robot is shutting down now ("" when it is not)."""
        why = self.middleware_down or (self.down and self._still_down()) or ""
        return why or self._nodes_down_reason(ours)

    def _still_down(self) -> str:
        """While the robot is down: still more nodes stopped than the share allows?"""
        if self.middleware_down:
            return self.middleware_down
        known = len(self.running)
        stopped = sum(1 for n in self.went_down if self.running.get(n) is False)
        return self.down if stopped > self.settings.shutdown_fraction * known else ""

    def back(self, now: float) -> str:
        """The robot is back: a node that has not come back is in its bring-up again."""
        self.down = ""
        self.back_at = now
        self.seen_running = {n for n, r in self.running.items() if r}
        self.went_down.clear()
        return (
            f"the robot is back ({len(self.seen_running)} of {len(self.running)} nodes "
            f"running): repairing again, with a bring-up grace of "
            f"{self.settings.startup_grace_s:g} s for the others"
        )

    def settling(self, now: float, ours: Collection[str]) -> bool:
        """Several nodes stopped within the window and the last one just now: the robot
        may be shutting down; wait until the nodes settle."""
        together = self.stopping_together(ours)
        if len(together) < 2:
            return False
        return now - self.went_down[together[-1]] < self.settings.shutdown_window_s

    def grace_ends(self, node: str) -> float | None:
        """When a node never seen running may be acted on (None: it was seen running)."""
        if node in self.seen_running:
            return None
        start = max(self.begun, self.back_at, self.heard.get(node, self.begun))
        return start + self.settings.startup_grace_s
