"""The repair node's logic: Algorithm 11 on the live diagnosis, with the care of a supervisor.

On a diagnosis Δ ≠ ∅ it builds the planning problem from Δ and the observations Θ, plans
with Fast Downward (:mod:`rac.repair`) and executes the plan step by step through an
:class:`Actuator` the transport provides.  Unlike the dissertation (§7.1.2.2, which only
waits for the action server), each step waits until its effect shows in Θ:

    stop_node(n)  ¬running(n)      start_node(n)  running(n)
    shutdown(d)   ¬on(d)           power_up(d)    on(d)

A repair must never touch a healthy node, so the executor acts only when every rule below
lets it (docs/runtime.md, "Repair engine", gives them with their defaults and options):

- confirmation: a diagnosis must stand ``confirm_s`` unchanged before a plan;
- before every step the diagnosis is read again: a step goes ahead only while a standing
  diagnosis names its target (or a component the plan already acted on); a cleared
  diagnosis aborts the plan, except for the steps that bring back what the plan itself
  stopped or shut down;
- bring-up grace: a node never seen running is not acted on until ``startup_grace_s`` has
  passed since the executor started, since the node first showed in Θ and since the robot
  last came back;
- a restart budget per component (``budget`` repairs in ``budget_window_s``) with an
  exponential back-off between repairs of the same component (``backoff_s``, doubled each
  time); a component over its budget is escalated (RAC110) and left alone until the oldest
  repair leaves the window;
- robot shutdown: when the transport says its middleware is gone (ROS 1: the master), or
  more than ``shutdown_fraction`` of the nodes stop within ``shutdown_window_s`` of each
  other, the robot is shutting down: nothing is repaired until it is back; while several
  nodes are stopping, planning waits for them to settle;
- a step whose effect does not show within ``step_timeout_s`` of its request is tried once
  more (a node that does not stop is killed), with a full time-out again, then the repair
  is abandoned with an escalation (RAC110);
- actuator calls may run on a thread of their own (``background``), so that a call that
  hangs (XML-RPC to a frozen node) never stalls the loop; times in the log run from the
  moment the request was made.

In advisory mode the plan is published and executed only when an operator confirms its id
(:meth:`RepairExecutor.confirm`); a dry run logs the plan and never acts.  After the last
step the executor waits for the engine to publish an empty diagnosis (verified); a
diagnosis that stands and names none of the components the plan touched is a new fault,
repaired at once.  Every decision goes to ``log`` as a :class:`LogEntry`.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
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
RESTORES = {"start_node": "stop_node", "power_up": "shutdown"}  # undoes what the plan did
NODE_ACTIONS = ("stop_node", "start_node")
QUICK_CALL_S = 0.05  # how long a tick waits for an actuator call before moving on


class Actuator(Protocol):
    """What a transport does for the executor.  Each call returns once the request is made
    (the executor verifies the effect itself), optionally with a note for the log (how a
    node was started), and raises RacError when the request cannot be made."""

    def stop_node(self, node: str) -> str | None:
        """Ask the node to stop (a polite request: XML-RPC shutdown, SIGINT, SIGTERM)."""
        ...

    def kill_node(self, node: str) -> str | None:
        """Kill the node's local process (SIGKILL): a node that did not stop when asked."""
        ...

    def start_node(self, node: str) -> str | None:
        """Start the node so that it belongs to the robot: it outlives racc."""
        ...

    def switch(self, device: str, on: bool) -> str | None: ...


class Mode(Enum):
    ACT = "act"  # plan and execute
    ADVISE = "advise"  # plan, publish, execute once an operator confirms the plan's id
    DRY_RUN = "dry-run"  # plan and log what would be done; never act


@dataclass(frozen=True, slots=True)
class Settings:
    confirm_s: float = 2.0  # a diagnosis must stand this long (a blip is not repaired)
    startup_grace_s: float = 30.0  # a node never seen running is left alone this long
    step_timeout_s: float = 5.0  # for an effect to show, from the request
    unobservable_pause_s: float = 1.0  # an effect no observer reports is assumed after this
    verify_timeout_s: float = 10.0  # for the engine to publish "no fault" after a plan
    budget: int = 3  # repairs of one component ...
    budget_window_s: float = 600.0  # ... within this window; then it is escalated
    backoff_s: float = 10.0  # before a component's second repair in the window; doubles
    no_plan_retry_s: float = 30.0  # after a diagnosis no plan repairs, before planning again
    shutdown_fraction: float = 0.5  # more nodes than this share stopping at once: shutdown
    shutdown_window_s: float = 3.0  # "at once": each within this of the previous one
    planner_timeout_s: float = 30.0
    strategy: str = "minimal"
    mode: Mode = Mode.ACT


@dataclass(frozen=True, slots=True)
class LogEntry:
    t: float  # epoch seconds, as every racc node logs
    level: int  # 0 OK, 1 WARN, 2 ERROR (diagnostic levels)
    action: str  # "plan", "stop_node", ..., "verify", "escalate", "hold", "robot", ...
    target: str
    message: str

    def row(self) -> Row:
        return Row(self.action, self.level, self.message, self.target, (("t", f"{self.t:.3f}"),))

    def __str__(self) -> str:
        level = {OK: "ok", WARN: "warn", ERROR: "error"}.get(self.level, str(self.level))
        return f"t={self.t:.3f} repair {level} {self.action}({self.target}): {self.message}"


class State(Enum):
    IDLE = "idle"
    ADVISED = "advised"  # a plan waits for an operator's confirmation
    EXECUTING = "executing"
    VERIFYING = "verifying"


@dataclass(slots=True)
class Budget:
    """One component's repairs: when each began (within the window), when the last ended,
    and until when it is escalated (its budget spent)."""

    began: list[float] = field(default_factory=list)
    last_end: float = float("-inf")
    escalated_until: float = float("-inf")

    def used(self, now: float, window: float) -> int:
        self.began[:] = [t for t in self.began if t > now - window]
        return len(self.began)


class Request:
    """One actuator call, inline or on a thread of its own (a call that hangs then only
    keeps its thread)."""

    def __init__(self, call: Callable[[], str | None], background: bool) -> None:
        self.done = False
        self.note: str | None = None
        self.error: str | None = None
        if background:
            thread = threading.Thread(target=self._run, args=(call,), daemon=True)
            thread.start()
            thread.join(QUICK_CALL_S)  # most calls return at once: seen in this tick
        else:
            self._run(call)

    def _run(self, call: Callable[[], str | None]) -> None:
        try:
            self.note = call()
        except RacError as err:
            self.error = "; ".join(d.message for d in err.diagnostics)
        except Exception as err:  # an actuator's bug must fail the step, not the loop
            self.error = f"{type(err).__name__}: {err}"
        self.done = True


def _steps(plan: Iterable[Step]) -> str:
    return ", ".join(f"{a}({','.join(args)})" for a, *args in plan)


def _at(t: float) -> str:
    """An epoch time for a message: the clock time and the epoch seconds."""
    if not math.isfinite(t):
        return "never"
    return f"{time.strftime('%H:%M:%S', time.gmtime(t))} UTC (t={t:.1f})"


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
        background: bool = False,
    ) -> None:
        self.theory, self.robot, self.actuator = theory, robot, actuator
        self.nodes = dict(nodes or {})  # component -> ROS node name
        self.devices = dict(devices or {})  # component -> device name
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
        self._acted: list[Step] = []  # the steps requested in this plan
        self._unverified = 0  # plans in a row that ran but left a fault
        self.budgets: dict[str, Budget] = {}
        # Nodes as Θ shows them: for the bring-up grace and the robot's shutdown.
        self.begun = clock()
        self._back_at = self.begun  # when the robot last came back
        self._heard: dict[str, float] = {}  # node -> when Θ first said anything of it
        self._running: dict[str, bool] = {}
        self._seen_running: set[str] = set()
        self._went_down: dict[str, float] = {}  # node -> when it stopped (was running)
        self._middleware_down = ""  # why the transport says the robot's middleware is gone
        self.robot_down = ""  # why the robot is shutting down ("" while it runs)
        self.repairs = 0  # plans verified
        self.escalations = 0

    # -- inputs --------------------------------------------------------------------------
    def observe(self, verdict: Verdict) -> None:
        self.observations.add(verdict)
        atom = verdict.atom
        if atom.predicate != "running" or len(atom.args) != 1:
            return
        node, now = atom.args[0], self.clock()
        self._heard.setdefault(node, now)
        was = self._running.get(node)
        self._running[node] = verdict.positive
        if verdict.positive:
            self._seen_running.add(node)
            self._went_down.pop(node, None)
        elif was:
            self._went_down[node] = now

    def diagnosis(self, diagnoses: tuple[tuple[str, ...], ...] | None) -> None:
        """The engine's latest diagnoses (empty: no fault; None: nothing explains Θ)."""
        now = self.clock()
        if diagnoses != self._diagnoses:
            self._since = now
        self._diagnoses = diagnoses
        self._diagnosis_t = now

    def middleware(self, up: bool, why: str = "") -> None:
        """The transport's word on the robot's middleware (ROS 1: is the master there?)."""
        self._middleware_down = "" if up else (why or "the middleware is gone")

    def confirm(self, plan_id: str) -> None:
        """An operator confirms the advised plan ``plan_id`` (advisory mode)."""
        wanted = plan_id.strip().removeprefix("plan").strip(" -")  # "3", "plan 3", "plan-3"
        if self.state is State.ADVISED and wanted == str(self.plan_id):
            self._confirmed = True
            self._emit(OK, "confirm", self.robot, f"plan {self.plan_id} confirmed by an operator")
            return
        pending = f"plan {self.plan_id}" if self.state is State.ADVISED else "none"
        self._emit(WARN, "confirm", self.robot, f"'{plan_id}' names no pending plan ({pending})")

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
        if self._robot_check(now):
            return
        if self.state is State.IDLE:
            self._maybe_plan(now)
        elif self.state is State.ADVISED:
            self._check_advised(now)
        elif self.state is State.EXECUTING:
            self._check_step(now)
        else:
            self._check_verified(now)

    def _emit(self, level: int, action: str, target: str, message: str) -> None:
        self._log(LogEntry(self.clock(), level, action, target, message))

    # -- the robot as a whole ------------------------------------------------------------
    def _stopping_together(self) -> list[str]:
        """The nodes that stopped last, each within shutdown_window_s of the one before
        (not those the plan under way stopped itself)."""
        ours = {s[1] for s in self._acted if s[0] == "stop_node" and len(s) > 1}
        down = sorted(
            (t, n)
            for n, t in self._went_down.items()
            if self._running.get(n) is False and n not in ours
        )
        group: list[tuple[float, str]] = []
        for t, n in down:
            if group and t - group[-1][0] > self.settings.shutdown_window_s:
                group = []
            group.append((t, n))
        return [n for _, n in group]

    def _nodes_down_reason(self) -> str:
        together = self._stopping_together()
        known = len(self._running)
        if len(together) >= 2 and len(together) > self.settings.shutdown_fraction * known:
            return f"{len(together)} of {known} nodes stopped together"
        return ""

    def _robot_check(self, now: float) -> bool:
        """Is the robot shutting down?  Logged once when it starts and when it is back."""
        why = self._middleware_down or (self.robot_down and self._still_down()) or ""
        if not why:
            why = self._nodes_down_reason()
        if why and not self.robot_down:
            self.robot_down = why
            self._emit(
                WARN, "robot", self.robot, f"the robot is shutting down ({why}): repairing nothing"
            )
            if self.state in (State.EXECUTING, State.VERIFYING, State.ADVISED):
                self._end_plan(now, f"plan {self.plan_id} abandoned: the robot is shutting down")
            return True
        if not why and self.robot_down:
            self.robot_down = ""
            self._back_at = now
            # A node that has not come back is in its bring-up again.
            self._seen_running = {n for n, r in self._running.items() if r}
            self._went_down.clear()
            running = len(self._seen_running)
            self._emit(
                OK,
                "robot",
                self.robot,
                f"the robot is back ({running} of {len(self._running)} nodes running): "
                f"repairing again, with a bring-up grace of {self.settings.startup_grace_s:g} s "
                "for the others",
            )
        return bool(self.robot_down)

    def _still_down(self) -> str:
        """While the robot is down: still more nodes stopped than the share allows?"""
        if self._middleware_down:
            return self._middleware_down
        known = len(self._running)
        stopped = sum(1 for n in self._went_down if self._running.get(n) is False)
        return self.robot_down if stopped > self.settings.shutdown_fraction * known else ""

    def _settling(self, now: float) -> bool:
        """Several nodes stopped within the window and the last one just now: the robot
        may be shutting down; wait until the nodes settle."""
        together = self._stopping_together()
        if len(together) < 2:
            return False
        return now - self._went_down[together[-1]] < self.settings.shutdown_window_s

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
        if now - self._since < self.settings.confirm_s or self._settling(now):
            return
        if self._hold_key == self._since and now < self._hold_until:
            return
        result = DiagnosisResult(False, (), diagnoses, self.theory.components, False)
        shown = self._shown()
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
        bad = ",".join(prepared.bad)
        what = (
            f"plan {self.plan_id}: diagnosis {shown}: repairing {bad} with {_steps(self.plan)} "
            f"(planned in {solved.planner_seconds:.2f} s; {self._budget_text(now, targets)})"
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
                f"{what}; waiting for an operator: publish the id {self.plan_id} on "
                "the repairer's ~confirm topic to execute it",
            )
            return
        self._emit(OK, "plan", bad, what)
        self._execute(now)

    def _blocked(self, now: float, plan: tuple[Step, ...], targets: list[str]) -> bool:
        """Does a rule hold the plan back (bring-up grace, budget, back-off)?  Logs why."""
        s = self.settings
        waits: list[tuple[float, str]] = []
        for c in sorted({step[1] for step in plan if step[0] in NODE_ACTIONS and len(step) > 1}):
            if c in self._seen_running:
                continue
            start = max(self.begun, self._back_at, self._heard.get(c, self.begun))
            if now < start + s.startup_grace_s:
                waits.append(
                    (
                        start + s.startup_grace_s,
                        f"{c} has not been seen running yet (bring-up grace until "
                        f"{_at(start + s.startup_grace_s)})",
                    )
                )
        for c in targets:
            budget = self.budgets.setdefault(c, Budget())
            used = budget.used(now, s.budget_window_s)
            if now < budget.escalated_until:
                waits.append(
                    (
                        budget.escalated_until,
                        f"{c} is escalated (RAC110): its repair budget frees at "
                        f"{_at(budget.escalated_until)}",
                    )
                )
            elif used >= s.budget:
                budget.escalated_until = budget.began[0] + s.budget_window_s
                self._escalated(
                    now,
                    f"{c} was repaired {used} times in {s.budget_window_s:g} s (its budget); "
                    f"racc stops acting on it until {_at(budget.escalated_until)}",
                )
                waits.append((budget.escalated_until, f"{c} is escalated (RAC110)"))
            elif used and now < budget.last_end + self._backoff(used):
                until = budget.last_end + self._backoff(used)
                waits.append(
                    (until, f"{c} was repaired {used} time(s) lately: back-off until {_at(until)}")
                )
        if not waits:
            self._held = ""
            return False
        level = ERROR if any("escalated" in why for _, why in waits) else OK
        until = max(t for t, _ in waits)
        self._hold(
            now, until, "; ".join(why for _, why in waits) + f": {_steps(plan)} waits", level
        )
        return True

    def _backoff(self, used: int) -> float:
        """The pause before a component's repair number ``used + 1`` in the window."""
        return float(self.settings.backoff_s * 2 ** max(used - 1, 0))

    def _budget_text(self, now: float, targets: list[str]) -> str:
        s = self.settings
        used = [
            f"{c} {self.budgets.setdefault(c, Budget()).used(now, s.budget_window_s) + 1}"
            for c in targets
        ]
        return f"repair {', '.join(used)} of {s.budget} in {s.budget_window_s:g} s"

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
                f"plan {self.plan_id} aborted before {_steps([step])}: {why}",
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
                self.budgets.setdefault(c, Budget()).began.append(now)
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
            self.budgets.setdefault(c, Budget()).last_end = now
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
            ("state", self.state.value),
            ("plans", str(self.plan_id)),
            ("verified", str(self.repairs)),
            ("escalations", str(self.escalations)),
        ]
        escalated = []
        for c, budget in sorted(self.budgets.items()):
            used = budget.used(now, s.budget_window_s)
            if not used and now >= budget.escalated_until:
                continue
            text = f"{used}/{s.budget} in {s.budget_window_s:g} s"
            if used and now < budget.last_end + self._backoff(used):
                text += f", back-off until {budget.last_end + self._backoff(used):.1f}"
            if now < budget.escalated_until:
                text += f", escalated until {budget.escalated_until:.1f}"
                escalated.append(c)
            values.append((f"budget {c}", text))
        if self.robot_down:
            level, message = WARN, f"the robot is shutting down ({self.robot_down})"
        elif escalated:
            level, message = ERROR, f"escalated (RAC110): {', '.join(escalated)}"
        elif self.state is State.ADVISED:
            level, message = WARN, f"plan {self.plan_id} awaits confirmation: {_steps(self.plan)}"
        elif self.state in (State.EXECUTING, State.VERIFYING):
            level, message = OK, f"{self.state.value} plan {self.plan_id}: {_steps(self.plan)}"
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
                _steps([step]),
                self._target(step),
                (("plan", str(self.plan_id)), ("diagnosis", self._shown())),
            )
            for k, step in enumerate(self.plan, 1)
        )
