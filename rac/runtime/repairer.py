"""The repair node's logic: Algorithm 11 on the live diagnosis, with verified steps.

On a diagnosis Δ ≠ ∅ it builds the planning problem from Δ and the observations Θ, plans
with Fast Downward (:mod:`rac.repair`) and executes the plan step by step through an
:class:`Actuator` the transport provides.  Unlike the dissertation (§7.1.2.2, which only
waits for the action server), each step waits until its effect shows in Θ:

    stop_node(n)  ¬running(n)      start_node(n)  running(n)
    shutdown(d)   ¬on(d)           power_up(d)    on(d)

with a time-out; a step whose effect does not show is tried once more, then the repair is
abandoned with an escalation message (RAC110) for a human.  An effect no observer reports
is assumed after a short pause.  After the last step the executor waits for the engine to
publish an empty diagnosis (verified) before it acts on a diagnosis again; a diagnosis that
stands and names none of the components the plan repaired or acted on is a new fault (one
that appeared during the repair): the repair counts as verified and the new fault is
repaired at once, instead of after the verification's time-out.  Every decision
goes to ``log`` as a :class:`LogEntry`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Protocol

from rac.diagnosis import DiagnosisResult, Theory
from rac.errors import Diagnostic, RacError
from rac.logic import Atom
from rac.observe import ObservationSet, Verdict
from rac.repair import NoRepairPlan, Step, prepare, solve
from rac.runtime.status import ERROR, OK, WARN, Row, row_diagnosis, row_verdict

EFFECTS = {  # action -> (predicate of the effect, its polarity)
    "stop_node": ("running", False),
    "start_node": ("running", True),
    "shutdown": ("on", False),
    "power_up": ("on", True),
}


class Actuator(Protocol):
    """What a transport does for the executor; each call returns once the request is made
    (the executor verifies the effect itself) and raises RacError when it cannot be made."""

    def stop_node(self, node: str) -> None: ...

    def start_node(self, node: str) -> None: ...

    def switch(self, device: str, on: bool) -> None: ...


@dataclass(frozen=True, slots=True)
class Settings:
    confirm_s: float = 0.5  # a diagnosis must stand this long (a blip is not repaired)
    step_timeout_s: float = 5.0  # for an effect to show
    unobservable_pause_s: float = 1.0  # an effect no observer reports is assumed after this
    verify_timeout_s: float = 10.0  # for the engine to publish "no fault" after a plan
    backoff_s: float = 30.0  # after an abandoned repair, before trying again
    planner_timeout_s: float = 30.0
    strategy: str = "minimal"


@dataclass(frozen=True, slots=True)
class LogEntry:
    t: float
    level: int  # 0 OK, 1 WARN, 2 ERROR (diagnostic levels)
    action: str  # "plan", "stop_node", ..., "verify", "escalate"
    target: str
    message: str

    def row(self) -> Row:
        return Row(self.action, self.level, self.message, self.target, (("t", f"{self.t:.3f}"),))

    def __str__(self) -> str:
        level = {OK: "ok", WARN: "warn", ERROR: "error"}.get(self.level, str(self.level))
        return f"t={self.t:.3f} repair {level} {self.action}({self.target}): {self.message}"


class State(Enum):
    IDLE = "idle"
    EXECUTING = "executing"
    VERIFYING = "verifying"


class RepairExecutor:
    def __init__(
        self,
        theory: Theory,
        robot: str,
        actuator: Actuator,
        log: Callable[[LogEntry], None],
        *,
        nodes: Mapping[str, str] | None = None,
        devices: Mapping[str, str] | None = None,
        settings: Settings = Settings(),
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.theory, self.robot, self.actuator = theory, robot, actuator
        self.nodes = dict(nodes or {})  # component -> ROS node name
        self.devices = dict(devices or {})  # component -> device name
        self.settings, self.clock, self._log = settings, clock, log
        self.observations = ObservationSet()
        self.observable = frozenset(theory.props)
        self.state = State.IDLE
        self.plan: tuple[Step, ...] = ()
        self._diagnoses: tuple[tuple[str, ...], ...] | None = ()
        self._diagnosis_t = float("-inf")
        self._since = float("-inf")  # when the diagnoses last changed
        self._quiet_until = float("-inf")
        self._step = 0
        self._attempt = 0
        self._deadline = 0.0
        self._started = 0.0
        self._step_started = 0.0
        self._plan_done = 0.0
        self._touched: frozenset[str] = frozenset()  # components the plan repairs or acts on
        self._unverified = 0  # plans in a row that ran but left a fault
        self.repairs = 0  # plans verified
        self.escalations = 0

    # -- inputs --------------------------------------------------------------------------
    def observe(self, verdict: Verdict) -> None:
        self.observations.add(verdict)

    def diagnosis(self, diagnoses: tuple[tuple[str, ...], ...] | None) -> None:
        """The engine's latest diagnoses (empty: no fault; None: nothing explains Θ)."""
        now = self.clock()
        if diagnoses != self._diagnoses:
            self._since = now
        self._diagnoses = diagnoses
        self._diagnosis_t = now

    def observation_rows(self, rows: Iterable[Row], t: float) -> None:
        """An ``/observations`` array, as a transport receives it."""
        for row in rows:
            verdict = row_verdict(row, t)
            if verdict is not None:
                self.observe(verdict)

    def diagnosis_rows(self, rows: Iterable[Row]) -> None:
        """A ``/diagnosis`` array (the "no diagnosis" row: nothing explains Θ)."""
        found = [row_diagnosis(r) for r in rows]
        if any(d is None for d in found):
            self.diagnosis(None)
        else:
            self.diagnosis(tuple(d for d in found if d is not None))

    # -- the loop ------------------------------------------------------------------------
    def tick(self) -> None:
        now = self.clock()
        if self.state is State.IDLE:
            self._maybe_plan(now)
        elif self.state is State.EXECUTING:
            self._check_step(now)
        else:
            self._check_verified(now)

    def _emit(self, level: int, action: str, target: str, message: str) -> None:
        self._log(LogEntry(self.clock(), level, action, target, message))

    def _maybe_plan(self, now: float) -> None:
        diagnoses = self._diagnoses
        if not diagnoses or self._diagnosis_t < self._quiet_until:
            return
        if now - self._since < self.settings.confirm_s:
            return
        shown = " | ".join("{" + ",".join(d) + "}" for d in diagnoses)
        result = DiagnosisResult(False, (), diagnoses, self.theory.components, False)
        try:
            prepared = prepare(
                self.theory,
                self.observations.literals(),
                self.robot,
                self.settings.strategy,
                diagnosis=result,
            )
            solved = solve(prepared, self.settings.planner_timeout_s)
        except (NoRepairPlan, RacError) as err:
            why = "; ".join(d.message for d in err.diagnostics)
            self._emit(ERROR, "plan", self.robot, f"no repair plan for {shown}: {why}")
            self._escalated(now, f"diagnosis {shown} cannot be repaired automatically")
            return
        self.plan = solved.plan
        self._touched = frozenset(prepared.bad) | {c for step in self.plan for c in step[1:]}
        if not self.plan:
            self._quiet_until = now + self.settings.verify_timeout_s
            return
        steps = ", ".join(f"{a}({','.join(args)})" for a, *args in self.plan)
        self._emit(
            OK,
            "plan",
            ",".join(prepared.bad),
            f"diagnosis {shown}: repairing {','.join(prepared.bad)} with {steps} "
            f"(planned in {solved.planner_seconds:.2f} s)",
        )
        self.state = State.EXECUTING
        self._started = now
        self._step = 0
        self._begin(now, attempt=1)

    def _target(self, step: Step) -> str:
        component = step[1] if len(step) > 1 else ""
        return self.nodes.get(component) or self.devices.get(component) or component

    def _begin(self, now: float, attempt: int) -> None:
        step = self.plan[self._step]
        action, target = step[0], self._target(step)
        self._attempt, self._step_started = attempt, now
        self._deadline = now + self.settings.step_timeout_s
        try:
            if action == "stop_node":
                self.actuator.stop_node(target)
            elif action == "start_node":
                self.actuator.start_node(target)
            elif action in ("shutdown", "power_up"):
                self.actuator.switch(target, action == "power_up")
            else:
                raise RacError([Diagnostic("RAC112", f"unknown repair action '{action}'")])
        except RacError as err:
            why = "; ".join(d.message for d in err.diagnostics)
            self._emit(ERROR, action, target, f"attempt {attempt} failed: {why}")
            self._deadline = now  # counts as a step whose effect did not show
            return
        self._emit(OK, action, target, f"attempt {attempt}: requested; waiting for its effect")

    def _effect(self, step: Step) -> tuple[Atom, bool] | None:
        predicate, positive = EFFECTS.get(step[0], ("", True))
        atom = Atom(predicate, tuple(step[1:]))
        return (atom, positive) if atom in self.observable else None

    def _holds(self, atom: Atom, positive: bool) -> bool:
        found = self.observations.literals()
        return any(lit.atom == atom and lit.positive == positive for lit in found)

    def _check_step(self, now: float) -> None:
        step = self.plan[self._step]
        action, target = step[0], self._target(step)
        effect = self._effect(step)
        if effect is None:
            done = now - self._step_started >= self.settings.unobservable_pause_s
            shown = "assumed (no observer reports it)"
        else:
            done = self._holds(*effect)
            literal = str(effect[0]) if effect[1] else f"{self.theory.neg_prefix}{effect[0]}"
            shown = f"{literal} observed after {now - self._step_started:.2f} s"
        if done:
            self._emit(OK, action, target, f"done: {shown}")
            self._step += 1
            if self._step < len(self.plan):
                self._begin(now, attempt=1)
            else:
                self.state = State.VERIFYING
                self._deadline = now + self.settings.verify_timeout_s
                self._plan_done = now
            return
        if now < self._deadline:
            return
        if self._attempt < 2:
            self._emit(WARN, action, target, "its effect did not show in time; trying once more")
            self._begin(now, attempt=2)
            return
        self._emit(
            ERROR,
            "escalate",
            target,
            f"RAC110: {action}({target}) did not take effect after 2 attempts "
            f"({self.settings.step_timeout_s:g} s each); the repair is abandoned, "
            "please repair by hand",
        )
        self._escalated(now, "")

    def _escalated(self, now: float, message: str) -> None:
        if message:
            self._emit(ERROR, "escalate", self.robot, f"RAC110: {message}; please repair by hand")
        self.escalations += 1
        self.state = State.IDLE
        self._quiet_until = now + self.settings.backoff_s

    def _verified(self, now: float, message: str, after: str = "", *, quiet_until: float) -> None:
        """The repair is verified: ``message`` with the time it took (then ``after``)."""
        self._emit(OK, "verify", self.robot, f"{message} in {now - self._started:.2f} s{after}")
        self.repairs += 1
        self._unverified = 0
        self.state = State.IDLE
        self._quiet_until = quiet_until

    def _shown(self) -> str:
        """The standing diagnoses as the log writes them: ``{a,b} | {c}``."""
        return " | ".join("{" + ",".join(d) + "}" for d in self._diagnoses or ())

    def _new_fault(self, now: float) -> bool:
        """Does a diagnosis stand that names nothing the plan touched (a fault that appeared
        during the repair)?  While a repaired node comes back, diagnoses still name it."""
        diagnoses = self._diagnoses
        if not diagnoses or now - self._since < self.settings.confirm_s:
            return False
        return not any(self._touched.intersection(d) for d in diagnoses)

    def _check_verified(self, now: float) -> None:
        fresh = self._diagnosis_t > self._plan_done
        if fresh and self._diagnoses == ():
            self._verified(now, "no fault: repaired", quiet_until=now)
        elif fresh and self._new_fault(now):
            # The diagnosis already stood after the plan: plan for it without waiting for
            # the engine's next message.
            repaired = f"{','.join(sorted(self._touched))} repaired"
            remains = f"; a new fault remains: {self._shown()}"
            self._verified(now, repaired, remains, quiet_until=self._diagnosis_t)
        elif now >= self._deadline:
            self._unverified += 1
            shown = self._shown()
            self._emit(
                WARN,
                "verify",
                self.robot,
                f"the plan ran but the diagnosis is still {shown or 'not empty'}",
            )
            if self._unverified >= 2:
                self._escalated(now, f"two repairs in a row left the fault {shown}")
                self._unverified = 0
            else:
                self.state = State.IDLE
                self._quiet_until = now
