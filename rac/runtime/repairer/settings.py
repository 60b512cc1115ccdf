"""What the repair executor works with: its settings and modes, the actuator a transport
provides, the log entries it writes, and the small records of its state (budgets, requests).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Protocol

from rac.errors import RacError
from rac.runtime.status import ERROR, OK, WARN, Row

if TYPE_CHECKING:
    from rac.repair import Step  # the planner is the repair node's, not every process's

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


def steps_text(plan: Iterable[Step]) -> str:
    return ", ".join(f"{a}({','.join(args)})" for a, *args in plan)


def at_text(t: float) -> str:
    """An epoch time for a message: the clock time and the epoch seconds."""
    if not math.isfinite(t):
        return "never"
    return f"{time.strftime('%H:%M:%S', time.gmtime(t))} UTC (t={t:.1f})"
