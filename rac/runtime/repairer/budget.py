"""The restart budget of every component (systemd's StartLimitBurst, Kubernetes'
CrashLoopBackOff): at most ``budget`` repairs in ``budget_window_s``, with a back-off of
``backoff_s`` doubled after each repair in the window; a component over its budget is
escalated and left alone until its oldest repair leaves the window."""

from __future__ import annotations

from collections.abc import Iterable

from rac.runtime.repairer.settings import Budget, Settings, at_text


class Budgets:
    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.by_component: dict[str, Budget] = {}

    def of(self, component: str) -> Budget:
        return self.by_component.setdefault(component, Budget())

    def backoff(self, used: int) -> float:
        """The pause before a component's repair number ``used + 1`` in the window."""
        return float(self.settings.backoff_s * 2 ** max(used - 1, 0))

    def waits(
        self, now: float, targets: Iterable[str]
    ) -> tuple[list[tuple[float, str]], list[str]]:
        """What holds a plan on ``targets`` back: (until when, why) for each, and the
        escalations it makes now (a component that just used its budget)."""
        s = self.settings
        waits: list[tuple[float, str]] = []
        escalations: list[str] = []
        for c in targets:
            budget = self.of(c)
            used = budget.used(now, s.budget_window_s)
            if now < budget.escalated_until:
                waits.append(
                    (
                        budget.escalated_until,
                        f"{c} is escalated (RAC110): its repair budget frees at "
                        f"{at_text(budget.escalated_until)}",
                    )
                )
            elif used >= s.budget:
                budget.escalated_until = budget.began[0] + s.budget_window_s
                escalations.append(
                    f"{c} was repaired {used} times in {s.budget_window_s:g} s (its budget); "
                    f"racc stops acting on it until {at_text(budget.escalated_until)}"
                )
                waits.append((budget.escalated_until, f"{c} is escalated (RAC110)"))
            elif used and now < budget.last_end + self.backoff(used):
                until = budget.last_end + self.backoff(used)
                why = f"{c} was repaired {used} time(s) lately: back-off until {at_text(until)}"
                waits.append((until, why))
        return waits, escalations

    def text(self, now: float, targets: Iterable[str]) -> str:
        """``repair jaguar_node 2 of 3 in 600 s``: the count this plan would make."""
        s = self.settings
        used = [f"{c} {self.of(c).used(now, s.budget_window_s) + 1}" for c in targets]
        return f"repair {', '.join(used)} of {s.budget} in {s.budget_window_s:g} s"

    def status(self, now: float) -> tuple[list[tuple[str, str]], list[str]]:
        """(``budget COMPONENT`` values, the components escalated now) for the status."""
        s = self.settings
        values, escalated = [], []
        for c, budget in sorted(self.by_component.items()):
            used = budget.used(now, s.budget_window_s)
            if not used and now >= budget.escalated_until:
                continue
            text = f"{used}/{s.budget} in {s.budget_window_s:g} s"
            if used and now < budget.last_end + self.backoff(used):
                text += f", back-off until {budget.last_end + self.backoff(used):.1f}"
            if now < budget.escalated_until:
                text += f", escalated until {budget.escalated_until:.1f}"
                escalated.append(c)
            values.append((f"budget {c}", text))
        return values, escalated
