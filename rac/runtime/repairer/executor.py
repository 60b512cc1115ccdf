"""The repair executor: Algorithm 11 on the live diagnosis, step by step, verified
(the rules are :mod:`rac.runtime.repairer`'s docstring)."""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable, Iterable, Mapping

from rac.diagnosis import DiagnosisResult, Theory
from rac.errors import Diagnostic, RacError
from rac.logic import Atom
from rac.observe import ObservationSet, Verdict
from rac.repair import NoRepairPlan, Step, prepare, solve
from rac.runtime.repairer.budget import Budgets
from rac.runtime.repairer.evidence import crashed, downstream
from rac.runtime.repairer.robot import RobotWatch
from rac.runtime.repairer.settings import (
    EFFECTS,
    NODE_ACTIONS,
    RESTORES,
    Actuator,
    LogEntry,
    Mode,
    Request,
    Settings,
    State,
    at_text,
    steps_text,
)
from rac.runtime.status import (
    ERROR,
    OK,
    WARN,
    Row,
    row_diagnosis,
    row_unknown,
    row_verdict,
)


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
        settings: Settings | None = None,
        clock: Callable[[], float] = time.time,
        background: bool = False,
    ) -> None:
        self.theory, self.robot, self.actuator = theory, robot, actuator
        self.nodes = dict(nodes or {})  # component -> ROS node name
        self.devices = dict(devices or {})  # component -> device name
        settings = settings or Settings()
        self.settings, self.clock, self._log = settings, clock, log
        self.background = background
        self.observations = ObservationSet()
        self.observable = frozenset(theory.props)
        self.state = State.IDLE
        self.plan: tuple[Step, ...] = ()
        self.plan_id = 0  # plans made so far; the current plan's id
        self._diagnoses: tuple[tuple[str, ...], ...] | None = ()
        self._diagnosis_t = float("-inf")
        self._since = float("-inf")  # when the diagnoses last changed
        self._quiet_until = float("-inf")
        self._hold_key = float("nan")  # the diagnosis (its _since) a hold is for
        self._hold_until = float("-inf")
        self._held = ""  # the last hold logged, so that it is logged once
        self._step = 0
        self._attempt = 0
        self._request: Request | None = None
        self._asked_at = 0.0  # when the current request was handed over
        self._step_started = 0.0  # when it was made (the call returned)
        self._deadline = 0.0
        self._started = 0.0
        self._plan_done = 0.0
        self._confirmed = False
        self._plan_key = float("nan")  # the diagnosis (its _since) the plan was made for
        self._failed = False  # the current attempt's request failed
        self._touched: frozenset[str] = frozenset()  # components the plan repairs or acts on
        self._below: frozenset[str] = frozenset()  # the components downstream of those
        self._acted: list[Step] = []  # the steps requested in this plan
        self._unverified = 0  # plans in a row that ran but left a fault
        self.budgets = Budgets(settings)
        # Nodes as Θ shows them: for the bring-up grace and the robot's shutdown.
        self.watch = RobotWatch(settings, clock())
        self._blind = ""  # why the diagnosis cannot be heard ("" while it is)
        # This run of the repairer: a confirmation names it, so that one meant for an
        # earlier run (whose plan 3 was another plan) confirms nothing.
        self.run = secrets.token_hex(4)
        self.repairs = 0  # plans verified
        self.escalations = 0

    # -- inputs --------------------------------------------------------------------------
    def observe(self, verdict: Verdict) -> None:
        self.observations.add(verdict)
        atom = verdict.atom
        if atom.predicate == "running" and len(atom.args) == 1:
            self.watch.observe(atom.args[0], verdict.positive, self.clock())

    def diagnosis(self, diagnoses: tuple[tuple[str, ...], ...] | None) -> None:
        """The engine's latest diagnoses (empty: no fault; None: nothing explains Θ)."""
        now = self.clock()
        if diagnoses != self._diagnoses:
            self._since = now
        self._diagnoses = diagnoses
        self._diagnosis_t = now

    def middleware(self, up: bool, why: str = "") -> None:
        """The transport's word on the robot's middleware (ROS 1: is the master there?)."""
        self.watch.middleware_down = "" if up else (why or "the middleware is gone")

    def confirm(self, plan_id: str, operator: str = "an operator", run: str = "") -> None:
        """``operator`` confirms the advised plan ``plan_id`` (advisory mode); ``run``, when
        given, must be this executor's :attr:`run` (a confirmation meant for an earlier run
        of the repairer, whose plan 3 was another plan, confirms nothing)."""
        wanted = plan_id.strip().removeprefix("plan").strip(" -")  # "3", "plan 3", "plan-3"
        if run and run != self.run:
            self._emit(
                WARN,
                "confirm",
                self.robot,
                f"confirmation of plan {wanted} by {operator} refused: it is for another run "
                f"of the repairer ({run}, this one is {self.run})",
            )
            return
        if self.state is State.ADVISED and wanted == str(self.plan_id):
            self._confirmed = True
            self._emit(OK, "confirm", self.robot, f"plan {self.plan_id} confirmed by {operator}")
            return
        pending = f"plan {self.plan_id}" if self.state is State.ADVISED else "none"
        self._emit(
            WARN,
            "confirm",
            self.robot,
            f"'{plan_id}' (from {operator}) names no pending plan ({pending})",
        )

    def blind(self, why: str) -> None:
        """The transport's word on the diagnosis ("": the engine is heard; else why not):
        while it is blind, nothing is planned, confirmed or begun but a step that brings
        back what the plan stopped, and no repair is judged."""
        if why and not self._blind:
            self._emit(ERROR, "blind", self.robot, f"diagnosis blind: {why}: acting on nothing")
        elif not why and self._blind:
            self._emit(OK, "blind", self.robot, "the diagnosis is back: acting again")
        self._blind = why

    def observation_rows(self, rows: Iterable[Row], t: float) -> None:
        """An ``/observations`` array, as a transport receives it.  An atom its observer
        withdrew (an ``unknown`` row) is out of Θ here too, as in the engine: its old
        verdict would make a step look done, or give the planner a state that is gone."""
        for row in rows:
            withdrawn = row_unknown(row)
            if withdrawn is not None:
                self.observations.discard(withdrawn)
                continue
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
        if self._robot_check(now):
            return
        if self._blind and self.state is State.VERIFYING:
            # Nothing can be verified without the engine: the time-out waits with it.
            self._deadline = max(self._deadline, now + self.settings.verify_timeout_s)
            return
        if self.state is State.IDLE:
            if not self._blind:
                self._maybe_plan(now)
        elif self.state is State.ADVISED:
            if not self._blind:
                self._check_advised(now)
        elif self.state is State.EXECUTING:
            self._check_step(now)
        else:
            self._check_verified(now)

    def _emit(self, level: int, action: str, target: str, message: str) -> None:
        self._log(LogEntry(self.clock(), level, action, target, message))

    # -- the robot as a whole ------------------------------------------------------------
    @property
    def robot_down(self) -> str:
        """Why the robot is shutting down ("" while it runs)."""
        return self.watch.down

    def _ours(self) -> set[str]:
        """The nodes the plan under way stopped itself."""
        return {s[1] for s in self._acted if s[0] == "stop_node" and len(s) > 1}

    def _robot_check(self, now: float) -> bool:
        """Is the robot shutting down?  Logged once when it starts and when it is back."""
        watch = self.watch
        why = watch.shutdown_reason(self._ours())
        if why and not watch.down:
            watch.down = why
            self._emit(
                WARN, "robot", self.robot, f"the robot is shutting down ({why}): repairing nothing"
            )
            if self.state in (State.EXECUTING, State.VERIFYING, State.ADVISED):
                self._end_plan(now, f"plan {self.plan_id} abandoned: the robot is shutting down")
            return True
        if not why and watch.down:
            self._emit(OK, "robot", self.robot, watch.back(now))
        return bool(watch.down)

    # -- planning ------------------------------------------------------------------------
    def _hold(self, now: float, until: float, message: str, level: int = OK) -> None:
        """No plan for this diagnosis before ``until`` (logged once per reason)."""
        self._hold_key, self._hold_until = self._since, until
        if message != self._held:
            self._held = message
            self._emit(level, "hold", self.robot, message)

    def _maybe_plan(self, now: float) -> None:
        diagnoses = self._diagnoses
        if not diagnoses or self._diagnosis_t < self._quiet_until:
            self._held = ""
            return
        if now - self._since < self.settings.confirm_s or self.watch.settling(now, self._ours()):
            return
        if self._hold_key == self._since and now < self._hold_until:
            return
        shown = self._shown()
        # A node Θ shows not running is repaired first, alone (rac.runtime.repairer.evidence).
        first = crashed(diagnoses, self.observations)
        if first and any(set(d) - set(first) for d in diagnoses):
            shown = f"{shown}; the crashed {', '.join(first)} first"
            diagnoses = (first,)
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
            self._quiet_until = now + self.settings.no_plan_retry_s
            return
        if not solved.plan:
            self._quiet_until = now + self.settings.verify_timeout_s
            return
        now = self.clock()  # planning takes time
        targets = sorted({c for step in solved.plan for c in step[1:]})
        if self._blocked(now, solved.plan, targets):
            return
        self.plan_id += 1
        self.plan, self._plan_key = solved.plan, self._since
        self._touched = frozenset(prepared.bad) | set(targets)
        self._below = downstream(self.theory, self._touched)
        bad = ",".join(prepared.bad)
        what = (
            f"plan {self.plan_id}: diagnosis {shown}: repairing {bad} with {steps_text(self.plan)} "
            f"(planned in {solved.planner_seconds:.2f} s; {self.budgets.text(now, targets)})"
        )
        mode = self.settings.mode
        if mode is Mode.DRY_RUN:
            self._hold(now, float("inf"), f"dry run: would execute {what}; acting on nothing")
            return
        if mode is Mode.ADVISE:
            self.state, self._confirmed = State.ADVISED, False
            self._emit(
                WARN,
                "advise",
                bad,
                f"{what}; waiting for an operator: 'racc confirm {self.plan_id}' executes it",
            )
            return
        self._emit(OK, "plan", bad, what)
        self._execute(now)

    def _blocked(self, now: float, plan: tuple[Step, ...], targets: list[str]) -> bool:
        """Does a rule hold the plan back (bring-up grace, budget, back-off)?  Logs why."""
        waits: list[tuple[float, str]] = []
        for c in sorted({step[1] for step in plan if step[0] in NODE_ACTIONS and len(step) > 1}):
            ends = self.watch.grace_ends(c)
            if ends is not None and now < ends:
                waits.append(
                    (
                        ends,
                        f"{c} has not been seen running yet (bring-up grace until {at_text(ends)})",
                    )
                )
        budget_waits, escalations = self.budgets.waits(now, targets)
        waits += budget_waits
        for message in escalations:
            self._escalated(now, message)
        if not waits:
            self._held = ""
            return False
        level = ERROR if any("escalated" in why for _, why in waits) else OK
        until = max(t for t, _ in waits)
        self._hold(
            now, until, "; ".join(why for _, why in waits) + f": {steps_text(plan)} waits", level
        )
        return True

    def _check_advised(self, now: float) -> None:
        if self._since != self._plan_key:
            self._emit(
                OK,
                "advise",
                self.robot,
                f"plan {self.plan_id} withdrawn: the diagnosis is now {self._shown() or 'empty'}",
            )
            self.state = State.IDLE
            return
        if self._confirmed:
            self._execute(now)

    def _execute(self, now: float) -> None:
        """Begin the plan; its first step goes in the next tick, after fresh inputs."""
        self.state = State.EXECUTING
        self._started = now
        self._step = 0
        self._attempt = 0
        self._request = None
        self._acted = []

    # -- steps ---------------------------------------------------------------------------
    def _target(self, step: Step) -> str:
        component = step[1] if len(step) > 1 else ""
        return self.nodes.get(component) or self.devices.get(component) or component

    def _restores(self, step: Step) -> bool:
        """Does ``step`` bring back what this plan stopped or shut down?"""
        undone = RESTORES.get(step[0])
        return undone is not None and (undone, *step[1:]) in self._acted

    def _may_go(self, step: Step) -> str:
        """Why ``step`` must not go ahead ("" when it may)."""
        if self._restores(step):
            return ""
        if self._blind:
            return f"the diagnosis is blind ({self._blind})"
        diagnoses = self._diagnoses
        if diagnoses == ():
            return "the diagnosis cleared"
        if diagnoses is None:
            return ""
        named = {c for d in diagnoses for c in d}
        acted = {c for s in self._acted for c in s[1:]}
        if named & (set(step[1:]) | acted):
            return ""
        return f"{','.join(step[1:])} is no longer diagnosed (the diagnosis is {self._shown()})"

    def _next_step(self, now: float) -> None:
        step = self.plan[self._step]
        why = self._may_go(step)
        if why:
            self._emit(
                WARN,
                "abort",
                self._target(step),
                f"plan {self.plan_id} aborted before {steps_text([step])}: {why}",
            )
            self._end_plan(now, "")
            return
        effect = self._effect(step)
        if effect is not None and self._holds(*effect):
            self._emit(OK, step[0], self._target(step), f"done: {self._literal(effect)} already")
            self._advance(now)
            return
        self._begin(now, attempt=1)

    def _call(self, step: Step, attempt: int) -> Callable[[], str | None]:
        action, target = step[0], self._target(step)
        a = self.actuator
        if action == "stop_node":
            return (lambda: a.kill_node(target)) if attempt > 1 else (lambda: a.stop_node(target))
        if action == "start_node":
            return lambda: a.start_node(target)
        if action in ("shutdown", "power_up"):
            return lambda: a.switch(target, action == "power_up")

        def unknown() -> str | None:
            raise RacError([Diagnostic("RAC112", f"unknown repair action '{action}'")])

        return unknown

    def _begin(self, now: float, attempt: int) -> None:
        step = self.plan[self._step]
        self._attempt, self._asked_at = attempt, now
        for c in step[1:]:
            if not any(c in s[1:] for s in self._acted):
                self.budgets.of(c).began.append(now)
        self._acted.append(step)
        self._request = Request(self._call(step, attempt), self.background)
        self._poll_request(self.clock())

    def _poll_request(self, now: float) -> bool:
        """Has the current request been made (the call returned)?  Logs its outcome once."""
        request = self._request
        if request is None or not request.done:
            return False
        self._request = None
        step = self.plan[self._step]
        action, target = step[0], self._target(step)
        self._step_started = now
        self._deadline = now + self.settings.step_timeout_s
        took = now - self._asked_at
        slow = f" (the call took {took:.2f} s)" if took >= 0.5 else ""
        if request.error is not None:
            self._emit(
                ERROR, action, target, f"attempt {self._attempt} failed{slow}: {request.error}"
            )
            self._failed = True
            return True
        self._failed = False
        note = f"; {request.note}" if request.note else ""
        verb = "killed (SIGKILL)" if action == "stop_node" and self._attempt > 1 else "requested"
        self._emit(
            OK,
            action,
            target,
            f"attempt {self._attempt}: {verb}{slow}{note}; waiting for its effect",
        )
        return True

    def _effect(self, step: Step) -> tuple[Atom, bool] | None:
        predicate, positive = EFFECTS.get(step[0], ("", True))
        atom = Atom(predicate, tuple(step[1:]))
        return (atom, positive) if atom in self.observable else None

    def _literal(self, effect: tuple[Atom, bool]) -> str:
        atom, positive = effect
        return str(atom) if positive else f"{self.theory.neg_prefix}{atom}"

    def _holds(self, atom: Atom, positive: bool) -> bool:
        found = self.observations.literals()
        return any(lit.atom == atom and lit.positive == positive for lit in found)

    def _advance(self, now: float) -> None:
        self._step += 1
        self._attempt = 0  # the next step is not begun yet
        if self._step >= len(self.plan):
            self.state = State.VERIFYING
            self._deadline = now + self.settings.verify_timeout_s
            self._plan_done = now

    def _check_step(self, now: float) -> None:
        s = self.settings
        if self._attempt == 0:  # the step is not begun: check it may go, then begin it
            self._next_step(now)
            return
        step = self.plan[self._step]
        action, target = step[0], self._target(step)
        if self._request is not None:
            if self._poll_request(now):
                return
            if now - self._asked_at < self.settings.step_timeout_s:
                return
            self._emit(
                ERROR,
                action,
                target,
                f"attempt {self._attempt}: the request did not return within "
                f"{self.settings.step_timeout_s:g} s",
            )
            self._request = None
            self._retry_or_escalate(now, step)
            return
        effect = self._effect(step)
        if effect is None:  # assumed, unless the request failed
            done = not self._failed and now - self._step_started >= s.unobservable_pause_s
            shown = "assumed (no observer reports it)"
        else:  # a failed request whose effect shows anyway (the node stopped by itself)
            done = self._holds(*effect)
            shown = f"{self._literal(effect)} observed after {now - self._step_started:.2f} s"
        if done:
            self._emit(OK, action, target, f"done: {shown}")
            self._advance(now)
            return
        if now < self._deadline:
            return
        self._retry_or_escalate(now, step)

    def _retry_or_escalate(self, now: float, step: Step) -> None:
        action, target = step[0], self._target(step)
        timeout = self.settings.step_timeout_s
        if self._attempt < 2:
            if action == "stop_node":
                why = f"it did not stop within {timeout:g} s; killing it"
            else:
                why = f"its effect did not show within {timeout:g} s; trying once more"
            self._emit(WARN, action, target, why)
            self._begin(now, attempt=2)
            return
        self._emit(
            ERROR,
            "escalate",
            target,
            f"RAC110: {action}({target}) did not take effect after 2 attempts "
            f"({timeout:g} s each); plan {self.plan_id} is abandoned, please repair by hand",
        )
        self.escalations += 1
        self._end_plan(now, "")

    def _end_plan(self, now: float, message: str) -> None:
        """The plan is over (verified or not, aborted, abandoned): the back-off of what it
        acted on runs from now."""
        if message:
            self._emit(WARN, "abort", self.robot, message)
        for c in {c for s in self._acted for c in s[1:]}:
            self.budgets.of(c).last_end = now
        self.state = State.IDLE
        self._request = None
        self._attempt = 0
        self._acted = []
        self._quiet_until = now

    def _escalated(self, now: float, message: str) -> None:
        self._emit(ERROR, "escalate", self.robot, f"RAC110: {message}; please repair by hand")
        self.escalations += 1

    # -- verification --------------------------------------------------------------------
    def _verified(self, now: float, message: str, after: str = "", *, quiet_until: float) -> None:
        """The repair is verified: ``message`` with the time it took (then ``after``)."""
        self._emit(
            OK,
            "verify",
            self.robot,
            f"plan {self.plan_id}: {message} in {now - self._started:.2f} s{after}",
        )
        self.repairs += 1
        self._unverified = 0
        self._end_plan(now, "")
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
        if any(self._touched.intersection(d) for d in diagnoses):
            return False
        # Nodes below a repaired one receive again only once they have reconnected, and
        # their topics' observers need a window: until the verification times out, that is
        # the repair settling (rac.runtime.repairer.evidence).
        below = self._below
        return not all(set(d) <= below for d in diagnoses)

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
                f"plan {self.plan_id} ran but the diagnosis is still {shown or 'not empty'}",
            )
            self._end_plan(now, "")
            if self._unverified >= 2:
                self._escalated(now, f"two repairs in a row left the fault {shown}")
                self._unverified = 0
                self._quiet_until = now + self.settings.no_plan_retry_s

    # -- what it shows -------------------------------------------------------------------
    def status(self, name: str) -> Row:
        """The repairer's status on ``/diagnostics``: its state, and every component's
        budget (used, back-off, escalation) while it has repairs in the window."""
        now = self.clock()
        s = self.settings
        values: list[tuple[str, str]] = [
            ("mode", s.mode.value),
            ("run", self.run),
            ("state", self.state.value),
            ("plans", str(self.plan_id)),
            ("verified", str(self.repairs)),
            ("escalations", str(self.escalations)),
        ]
        budget_values, escalated = self.budgets.status(now)
        values += budget_values
        if self._blind:
            level, message = ERROR, f"diagnosis blind: {self._blind}: acting on nothing"
        elif self.robot_down:
            level, message = WARN, f"the robot is shutting down ({self.robot_down})"
        elif escalated:
            level, message = ERROR, f"escalated (RAC110): {', '.join(escalated)}"
        elif self.state is State.ADVISED:
            level, message = (
                WARN,
                f"plan {self.plan_id} awaits confirmation: {steps_text(self.plan)}",
            )
        elif self.state in (State.EXECUTING, State.VERIFYING):
            level, message = OK, f"{self.state.value} plan {self.plan_id}: {steps_text(self.plan)}"
        elif self._held and self._hold_key == self._since and now < self._hold_until:
            level, message = OK, f"holding: {self._held}"
        else:
            level, message = OK, "idle" if not self._diagnoses else "watching a diagnosis"
        return Row(f"{name}: repair", level, message, self.robot, tuple(values))

    def pending_rows(self) -> tuple[Row, ...]:
        """The advised plan awaiting confirmation, one row per step (none: no plan)."""
        if self.state is not State.ADVISED:
            return ()
        return tuple(
            Row(
                f"plan {self.plan_id} step {k}",
                WARN,
                steps_text([step]),
                self._target(step),
                (("plan", str(self.plan_id)), ("diagnosis", self._shown()), ("run", self.run)),
            )
            for k, step in enumerate(self.plan, 1)
        )
