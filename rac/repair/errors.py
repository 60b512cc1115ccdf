"""NoRepairPlan: why no repair plan exists; the commands exit 3 on it (docs/spec.md)."""

from __future__ import annotations

from rac.errors import Diagnostic, RacError


class NoRepairPlan(RacError):
    """No plan: a component cannot be repaired, the planner failed, timed out or found none."""

    def __init__(self, code: str, message: str, hint: str | None = None) -> None:
        super().__init__([Diagnostic(code, message, hint=hint)])
