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

from typing import TYPE_CHECKING

from rac.runtime.repairer.settings import (
    EFFECTS,
    Actuator,
    Budget,
    LogEntry,
    Mode,
    Request,
    Settings,
    State,
)

if TYPE_CHECKING:
    from rac.runtime.repairer.executor import RepairExecutor
    from rac.runtime.repairer.robot import RobotWatch


def __getattr__(name: str) -> object:
    # The executor plans with Fast Downward (rac.repair, jinja2's templates): imported when
    # a repair node asks for it, not by every racc process that needs an Actuator's shape
    # (an observer host starting beside three others on a robot's two cores).
    if name == "RepairExecutor":
        from rac.runtime.repairer.executor import RepairExecutor

        return RepairExecutor
    if name == "RobotWatch":
        from rac.runtime.repairer.robot import RobotWatch

        return RobotWatch
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "EFFECTS",
    "Actuator",
    "Budget",
    "LogEntry",
    "Mode",
    "RepairExecutor",
    "Request",
    "RobotWatch",
    "Settings",
    "State",
]
