"""``racc confirm``: an operator confirms the repair plan an advising repairer waits on.

The repairer in advisory mode publishes the plan awaiting confirmation on ``/repair_plan``
(latched: one row per step, with the plan's id and the repairer's ``run``) and executes it
only on a confirmation sealed by an operator (:mod:`rac.runtime.trust`): the plan's id and
the run it belongs to, sealed with the robot's secret and the operator's name, on the
repairer's ``~confirm`` topic.  This module reads the pending plan, sends the confirmation
and waits for the repairer's answer on ``/repair_log``; it needs no ROS CLI on either
version.  Transport-free: a :class:`rac.runtime.bus.Bus` carries it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from rac.errors import Diagnostic, RacError
from rac.runtime.bus import Bus
from rac.runtime.status import REPAIR_LOG, REPAIR_PLAN, Row
from rac.runtime.trust import CONFIRM, confirm_body

POLL_S = 0.05


@dataclass(frozen=True, slots=True)
class Pending:
    plan: str
    run: str
    steps: tuple[str, ...]
    diagnosis: str

    def lines(self) -> list[str]:
        head = f"plan {self.plan} (diagnosis {self.diagnosis or '?'}) awaits confirmation:"
        return [head, *(f"  {i}. {step}" for i, step in enumerate(self.steps, 1))]


def pending_of(rows: Sequence[Row]) -> Pending | None:
    """The plan a ``/repair_plan`` array holds (None: none awaits an operator)."""
    if not rows:
        return None
    first = rows[0]
    return Pending(
        first.value("plan"),
        first.value("run"),
        tuple(r.message for r in rows),
        first.value("diagnosis"),
    )


def confirm_topic(repairer: str) -> str:
    return f"/{repairer.strip('/')}/confirm"


def confirm(
    bus: Bus,
    plan: str | None,
    *,
    repairer: str = "racc_repairer",
    wait_s: float = 5.0,
    say: Callable[[str], None] = print,
) -> int:
    """Show the pending plan (``plan`` None), or confirm plan ``plan``: 0 once the repairer
    says it is confirmed; RAC151 when no such plan awaits, RAC152 when no repairer answers
    within ``wait_s``."""
    trust = bus.trust
    if trust is None:
        raise ValueError("racc confirm needs the robot's secret")
    lock = threading.Lock()
    seen: list[Pending | None] = []
    answers: list[Row] = []

    def on_plan(rows: list[Row]) -> None:
        with lock:
            seen.append(pending_of(rows))

    def on_log(rows: list[Row]) -> None:
        with lock:
            answers.extend(r for r in rows if r.name == "confirm")

    bus.on_rows(REPAIR_PLAN, on_plan, 5, latched=True)
    bus.on_rows(REPAIR_LOG, on_log, 50, latched=True)
    publish = bus.text_publisher(confirm_topic(repairer), 5)
    deadline = time.monotonic() + wait_s
    while (
        bus.ok
        and time.monotonic() < deadline
        and not (seen and (plan is None or publish.listeners()))
    ):
        time.sleep(POLL_S)
    with lock:
        pending = seen[-1] if seen else None
    if not seen:
        raise _no_repairer(repairer, wait_s, "published no /repair_plan")
    if pending is None:
        raise RacError(
            [
                Diagnostic(
                    "RAC151",
                    "no repair plan awaits confirmation"
                    + (f" (asked to confirm plan {plan})" if plan else ""),
                    hint="the repairer advises only with --mode advise (repair_mode:=advise); "
                    "'racc watch --only repair' shows its plans as they come",
                )
            ]
        )
    for line in pending.lines():
        say(line)
    if plan is None:
        say(f"confirm it with: racc confirm {pending.plan}")
        return 0
    wanted = plan.strip().removeprefix("plan").strip(" -")
    if wanted != pending.plan:
        raise RacError(
            [
                Diagnostic(
                    "RAC151",
                    f"plan {wanted} does not await confirmation; plan {pending.plan} does",
                    hint=f"racc confirm {pending.plan}",
                )
            ]
        )
    if not publish.listeners():
        raise _no_repairer(repairer, wait_s, f"does not listen on {confirm_topic(repairer)}")
    with lock:
        answers.clear()  # the latched last entry is an older one
    publish(trust.seal_text(CONFIRM, confirm_body(pending.plan, pending.run)))
    deadline = time.monotonic() + wait_s
    while bus.ok and time.monotonic() < deadline:
        with lock:
            mine = [
                r for r in answers if f"plan {pending.plan}" in r.message or wanted in r.message
            ]
        if mine:
            answer = mine[-1]
            say(f"{repairer}: {answer.message}")
            return 0 if answer.level == 0 else 1
        time.sleep(POLL_S)
    raise _no_repairer(repairer, wait_s, "did not answer the confirmation")


def _no_repairer(repairer: str, wait_s: float, what: str) -> RacError:
    return RacError(
        [
            Diagnostic(
                "RAC152",
                f"no repairer answered: {repairer} {what} within {wait_s:g} s",
                hint="is the runtime running (racc watch), on this ROS master or domain, "
                "and is --repairer its node's name? A confirmation is refused unless it is "
                "sealed with the robot's secret: give --secret where it is not the default",
            )
        ]
    )
