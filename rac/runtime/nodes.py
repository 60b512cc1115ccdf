"""The observer host's, the diagnosis and the repair nodes' main loops, written once for
both ROS versions.

A node needs little from ROS: publish and receive arrays of statuses, receive a string, log,
and know when to stop.  :class:`Bus` is that much; ``rac.ros1.common.Ros1Bus`` and
``rac.ros2.common.Session`` provide it over rospy and rclpy.  What the nodes decide is
:mod:`rac.runtime.host`'s, :mod:`rac.runtime.diagnoser`'s and :mod:`rac.runtime.repairer`'s.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from rac.diagnosis import Theory
from rac.passes.observers import DIAGNOSTICS_TOPIC
from rac.runtime.diagnoser import EngineLoop
from rac.runtime.host import HostLoop, ObserverHost, Schedule, ticks
from rac.runtime.procs import ProcessProbe
from rac.runtime.repairer import Actuator, LogEntry, RepairExecutor, Settings
from rac.runtime.routing import Agent
from rac.runtime.status import DIAGNOSIS, OBSERVATIONS, REPAIR_LOG, REPAIR_PLAN, Row

POLL_S = 0.05
STATUS_PERIOD_S = 1.0  # the repairer's status on /diagnostics


class Bus(Protocol):
    """One ROS node's connection to the graph, as the racc nodes use it."""

    @property
    def name(self) -> str:
        """The node's resolved name, without the leading '/'."""
        ...

    @property
    def ok(self) -> bool:
        """False once the node is asked to stop (Ctrl-C, SIGTERM, ROS shutdown)."""
        ...

    def log(self, level: int, text: str) -> None:
        """Log at a status level: 0 info, 1 warning, 2 and above error."""
        ...

    def rows_publisher(
        self, topic: str, depth: int, latched: bool = False
    ) -> Callable[[Sequence[Row]], None]:
        """Publish rows as one ``diagnostic_msgs/DiagnosticArray``; ``latched``: the last
        array is kept for subscribers that join later."""
        ...

    def on_rows(
        self, topic: str, callback: Callable[[list[Row]], None], depth: int, latched: bool = False
    ) -> None:
        """Call ``callback`` with the rows of each array on ``topic``; ``latched``: also
        receive the array a latched publisher kept."""
        ...

    def on_text(self, topic: str, callback: Callable[[str], None], depth: int) -> None:
        """Call ``callback`` with each ``std_msgs/String`` on ``topic`` (``~name``: the
        node's private topic)."""
        ...


def run_observer_node(
    bus: Bus,
    host: ObserverHost,
    probe: ProcessProbe,
    *,
    topics: int,
    sample_hz: float = 10.0,
    republish_s: float = 1.0,
    agent: Agent | None = None,
    machine: str | None = None,
    each_tick: Callable[[float], None] | None = None,
) -> None:
    """Run the observer host on ``/observations`` until the bus stops: every
    ``1/sample_hz`` s the machine's racc agent's reports are logged and go to
    ``/repair_log`` (its requests are carried out on its own thread), then
    :class:`HostLoop` samples and publishes (on a change, and every ``republish_s``).
    The transport has subscribed ``host`` to its ``topics`` already; ``each_tick`` runs
    first in each tick with the time (ROS 2 subscribes topics as they appear there)."""
    publish = bus.rows_publisher(OBSERVATIONS, 10, latched=True)
    bus.log(
        0,
        f"racc observe: {len(host.specs)} observers, {topics} topics, {len(probe.nodes)} nodes"
        + (f" (machine {machine})" if machine else ""),
    )
    period = 1.0 / sample_hz
    loop = HostLoop(host, probe, republish_s, Schedule(period_s=period))
    # the agent reports what its requests came to where the repairer's own steps go
    agent_log = bus.rows_publisher(REPAIR_LOG, 50, latched=True) if agent is not None else None
    for now in ticks(period, lambda: bus.ok):
        if each_tick is not None:
            each_tick(now)
        if agent is not None and agent_log is not None:
            reports = agent.reports()
            for entry in reports:
                bus.log(entry.level, str(entry))
            if reports:
                agent_log([entry.row() for entry in reports])
        step = loop.step(now)
        for line in step.lines:
            bus.log(0, line)
        for warning in step.warnings:
            bus.log(1, f"racc observe: {warning}")
        if step.rows is not None:
            publish(step.rows)


def run_engine_node(
    bus: Bus,
    path: str,
    load: Callable[[str], Theory],
    robot: str,
    *,
    rate_hz: float = 1.0,
    max_card: int | None = None,
) -> None:
    """Diagnose ``/observations`` on ``/diagnosis`` and ``/diagnostics`` until the bus stops;
    ``~reload`` replaces the model (a path, or empty for the same file)."""
    engine = EngineLoop(path, load, robot, bus.name, bus.log, rate_hz=rate_hz, max_card=max_card)
    publish = bus.rows_publisher(DIAGNOSIS, 10, latched=True)
    summary = bus.rows_publisher(DIAGNOSTICS_TOPIC, 10)
    bus.on_rows(
        OBSERVATIONS, lambda rows: engine.observation_rows(rows, time.time()), 50, latched=True
    )
    bus.on_text("~reload", engine.request_reload, 5)
    components = len(engine.diagnoser.theory.components)
    bus.log(0, f"racc engine: {path}, {components} components, {rate_hz:.3g} Hz")
    while bus.ok:
        time.sleep(min(POLL_S, engine.period))
        tick = engine.step(time.time())
        if tick is not None:
            publish(tick.rows)
            summary([tick.summary, *tick.hosts])


@dataclass(frozen=True, slots=True, eq=False)
class RepairJob:
    """What the repair node works on, whichever ROS carries it out."""

    theory: Theory
    robot: str
    launch_file: str | None  # the user's launch file, where start_node finds its entries
    nodes: Mapping[str, str]  # component -> ROS node name
    devices: Mapping[str, str]  # component -> device name
    settings: Settings
    rate_hz: float = 10.0
    # node -> (machine, container) from observers.yaml (rac.runtime.routing), and the
    # machine the repairer runs on: nodes elsewhere are restarted by their machine's agent.
    placements: Mapping[str, tuple[str | None, str | None]] = field(default_factory=dict)
    machine: str | None = None


def run_repair_node(
    bus: Bus,
    actuator: Actuator,
    job: RepairJob,
    after_tick: Callable[[], None] | None = None,
    middleware: Callable[[], tuple[bool, str]] | None = None,
) -> None:
    """Carry out :class:`RepairExecutor`'s repairs of what ``/observations`` and
    ``/diagnosis`` show, logging each step on ``/repair_log``, until the bus stops.

    The bus's callbacks only queue what they receive; the loop hands it to the executor
    before each tick, so a plan never goes ahead on a diagnosis that cleared while it was
    being made.  Actuator calls run on threads of their own (a call that hangs does not
    stall the loop).  The executor's status goes to ``/diagnostics`` once a second, the plan
    awaiting an operator (advisory mode) to ``/repair_plan`` (latched), and ``~confirm``
    (a ``std_msgs/String``: the plan's id) confirms it.  ``after_tick`` runs after each tick
    (an actuator reaps the processes it started there); ``middleware`` says whether the
    robot's middleware is there (ROS 1: the master), without blocking.
    """
    theory = job.theory
    log_pub = bus.rows_publisher(REPAIR_LOG, 50, latched=True)
    status_pub = bus.rows_publisher(DIAGNOSTICS_TOPIC, 10)
    plan_pub = bus.rows_publisher(REPAIR_PLAN, 5, latched=True)

    def log(entry: LogEntry) -> None:
        bus.log(entry.level, str(entry))
        log_pub([entry.row()])

    executor = RepairExecutor(
        theory,
        job.robot,
        actuator,
        log,
        nodes=job.nodes,
        devices=job.devices,
        settings=job.settings,
        background=True,
    )
    inbox: deque[Callable[[], None]] = deque()  # appended by the bus's threads

    def on_observations(rows: list[Row]) -> None:
        t = time.time()
        inbox.append(lambda: executor.observation_rows(rows, t))

    def on_diagnosis(rows: list[Row]) -> None:
        inbox.append(lambda: executor.diagnosis_rows(rows))

    def on_confirm(text: str) -> None:
        inbox.append(lambda: executor.confirm(text))

    bus.on_rows(OBSERVATIONS, on_observations, 50, latched=True)
    bus.on_rows(DIAGNOSIS, on_diagnosis, 10, latched=True)
    bus.on_text("~confirm", on_confirm, 5)
    s = job.settings
    bus.log(
        0,
        f"racc repairer: launch file {job.launch_file or '(none)'}, "
        f"{len(theory.components)} components, mode {s.mode.value}, confirm {s.confirm_s:g} s, "
        f"bring-up grace {s.startup_grace_s:g} s, budget {s.budget} in {s.budget_window_s:g} s",
    )
    period = 1.0 / job.rate_hz
    pending: tuple[Row, ...] | None = None
    next_status = 0.0
    while bus.ok:
        while inbox:
            inbox.popleft()()
        if middleware is not None:
            executor.middleware(*middleware())
        executor.tick()
        if executor.pending_rows() != pending:
            pending = executor.pending_rows()
            plan_pub(pending)
        now = time.time()
        if now >= next_status:
            status_pub([executor.status(bus.name)])
            next_status = now + STATUS_PERIOD_S
        if after_tick is not None:
            after_tick()
        time.sleep(period)
