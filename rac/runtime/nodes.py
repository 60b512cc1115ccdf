"""The observer host's, the diagnosis and the repair nodes' main loops, written once for
both ROS versions.

A node needs little from ROS: publish and receive arrays of statuses, receive a string, log,
and know when to stop.  :class:`rac.runtime.bus.Bus` is that much; ``rac.ros1.common.Ros1Bus``
and ``rac.ros2.common.Session`` provide it over rospy and rclpy.  What the nodes decide is
:mod:`rac.runtime.host`'s, :mod:`rac.runtime.diagnoser`'s and :mod:`rac.runtime.repairer`'s.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from rac.passes.observers import DIAGNOSTICS_TOPIC
from rac.runtime.bus import Bus
from rac.runtime.host import HostLoop, ObserverHost, Schedule, ticks
from rac.runtime.procs import ProcessProbe
from rac.runtime.repairer import Actuator, LogEntry, Settings
from rac.runtime.routing import Agent
from rac.runtime.status import DIAGNOSIS, OBSERVATIONS, REPAIR_LOG, REPAIR_PLAN, Row
from rac.runtime.trust import CONFIRM, read_confirm

if TYPE_CHECKING:
    from rac.diagnosis import Theory

POLL_S = 0.05
STATUS_PERIOD_S = 1.0  # the repairer's status on /diagnostics
# The engine publishes /diagnosis at least once a second (its heartbeat); a node that has
# heard none for this long is blind and says so (level 2), and the repairer acts on nothing.
ENGINE_LOST_S = 3.0


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
    publish = bus.rows_publisher(OBSERVATIONS, 10, latched=True, purpose=OBSERVATIONS)
    status_pub = bus.rows_publisher(DIAGNOSTICS_TOPIC, 10)
    trust = bus.trust
    if trust is not None:
        host.refuse = trust.refuse
    seen = [time.time()]  # when a /diagnosis was last admitted (the engine's heartbeat)

    def on_diagnosis(rows: list[Row]) -> None:
        seen[0] = time.time()

    bus.on_rows(
        DIAGNOSIS,
        on_diagnosis,
        5,
        latched=True,
        gate=trust.gate(DIAGNOSIS, latched=True) if trust is not None else None,
    )
    bus.log(
        0,
        f"racc observe: {len(host.specs)} observers, {topics} topics, {len(probe.nodes)} nodes"
        + (f" (machine {machine})" if machine else ""),
    )
    if not host.check.known:
        bus.log(
            1,
            "racc observe: the observers file names no topic's publishers (written by an "
            "older racc): every publisher's messages count; compile the model again",
        )
    period = 1.0 / sample_hz
    loop = HostLoop(host, probe, republish_s, Schedule(period_s=period))
    # the agent reports what its requests came to where the repairer's own steps go
    agent_log = bus.rows_publisher(REPAIR_LOG, 50, latched=True) if agent is not None else None
    blind = ""
    next_status = 0.0
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
        silence = engine_silence(seen[0], time.time())
        if bool(silence) != bool(blind):
            bus.log(2 if silence else 0, host_blind_line(now, silence))
        blind = silence
        if now >= next_status:
            cost = loop.cost.last
            status_pub(
                [
                    host_status(bus.name, blind),
                    *([cost.row(bus.name)] if cost is not None else []),
                    *([trust.row()] if trust is not None else []),
                ]
            )
            next_status = now + STATUS_PERIOD_S


def host_status(node: str, blind: str) -> Row:
    """The observer host's word on ``/diagnostics`` about the diagnosis it feeds."""
    name = f"{node}: diagnosis"
    if blind:
        return Row(name, 2, f"diagnosis blind: {blind}", "", (("blind", "1"),))
    return Row(name, 0, "the engine's heartbeat is heard", "", (("blind", "0"),))


def host_blind_line(t: float, blind: str) -> str:
    if blind:
        return f"t={t:.3f} diagnosis blind: {blind}; the observations go on unheard"
    return f"t={t:.3f} the engine's heartbeat is heard again"


def run_engine_node(
    bus: Bus,
    path: str,
    load: Callable[[str], Theory],
    robot: str,
    *,
    rate_hz: float = 1.0,
    max_card: int | None = None,
    hosts: Sequence[str] = (),
    reload_dir: str | None = None,
) -> None:
    """Diagnose ``/observations`` on ``/diagnosis`` and ``/diagnostics`` until the bus stops;
    ``~reload`` replaces the model (a path inside ``reload_dir``, or empty for the same
    file).  Observations count only from the observer hosts ``hosts`` (any, when empty)
    whose arrays carry the robot's seal; ``/diagnosis`` is sealed, and published at least
    once a second (the engine's heartbeat)."""
    from rac.runtime.diagnoser import EngineLoop  # the engine's process only

    engine = EngineLoop(
        path,
        load,
        robot,
        bus.name,
        bus.log,
        rate_hz=rate_hz,
        max_card=max_card,
        reload_dir=reload_dir,
    )
    publish = bus.rows_publisher(DIAGNOSIS, 10, latched=True, purpose=DIAGNOSIS)
    summary = bus.rows_publisher(DIAGNOSTICS_TOPIC, 10)
    trust = bus.trust
    gate = trust.gate(OBSERVATIONS, hosts, latched=True) if trust is not None else None

    def on_observations(rows: list[Row]) -> None:
        sent = trust.sent.get(OBSERVATIONS) if trust is not None else None
        engine.observation_rows(rows, time.time(), sent)

    bus.on_rows(OBSERVATIONS, on_observations, 50, latched=True, gate=gate)

    def on_reload(target: str, sender: str) -> None:
        why = engine.request_reload(target)
        if why is not None and trust is not None:
            trust.refuse(sender, "~reload", why)
        elif why is not None:
            bus.log(1, f"racc engine: reload of {target} refused: {why}")

    bus.on_text("~reload", on_reload, 5)
    components = len(engine.diagnoser.theory.components)
    bus.log(0, f"racc engine: {path}, {components} components, {rate_hz:.3g} Hz")
    while bus.ok:
        time.sleep(min(POLL_S, engine.period))
        tick = engine.step(time.time())
        if tick is not None:
            publish(tick.rows)
            summary([tick.summary, *tick.hosts, *([trust.row()] if trust is not None else [])])


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
    key: bytes | None = None  # the robot's racc secret (rac.load.secret)
    engine_lost_s: float = ENGINE_LOST_S  # without the engine's heartbeat: blind


def run_repair_node(
    bus: Bus,
    actuator: Actuator,
    job: RepairJob,
    after_tick: Callable[[], None] | None = None,
    middleware: Callable[[], tuple[bool, str]] | None = None,
) -> None:
    """Carry out :class:`RepairExecutor`'s repairs of what ``/observations`` and
    ``/diagnosis`` show, logging each step on ``/repair_log``, until the bus stops.
    Both count only when sealed by racc's observer hosts and engine; a confirmation only
    when sealed by an operator (``racc confirm``), whose name the log gives.  Without the
    engine's heartbeat for :data:`ENGINE_LOST_S` the repairer is blind (level 2 on
    ``/diagnostics``) and acts on nothing.

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

    from rac.runtime.repairer.executor import RepairExecutor  # the repair node's only

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
    trust = bus.trust
    seen = [time.time()]  # when a /diagnosis was last admitted (the engine's heartbeat)

    def on_observations(rows: list[Row]) -> None:
        t = time.time()
        inbox.append(lambda: executor.observation_rows(rows, t))

    def on_diagnosis(rows: list[Row]) -> None:
        seen[0] = time.time()
        inbox.append(lambda: executor.diagnosis_rows(rows))

    def on_confirm(text: str, operator: str) -> None:
        plan, run = read_confirm(text)
        inbox.append(lambda: executor.confirm(plan, operator or "an unsealed sender", run))

    gate = trust.gate if trust is not None else None
    bus.on_rows(
        OBSERVATIONS,
        on_observations,
        50,
        latched=True,
        gate=gate(OBSERVATIONS, latched=True) if gate else None,
    )
    bus.on_rows(
        DIAGNOSIS,
        on_diagnosis,
        10,
        latched=True,
        gate=gate(DIAGNOSIS, latched=True) if gate else None,
    )
    bus.on_text("~confirm", on_confirm, 5, gate=gate(CONFIRM) if gate else None)
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
        executor.blind(engine_silence(seen[0], time.time(), job.engine_lost_s))
        executor.tick()
        if executor.pending_rows() != pending:
            pending = executor.pending_rows()
            plan_pub(pending)
        now = time.time()
        if now >= next_status:
            status_pub([executor.status(bus.name), *([trust.row()] if trust is not None else [])])
            next_status = now + STATUS_PERIOD_S
        if after_tick is not None:
            after_tick()
        time.sleep(period)


def engine_silence(last: float, now: float, lost_after_s: float = ENGINE_LOST_S) -> str:
    """Why the diagnosis is blind ("" while the engine's heartbeat is heard)."""
    silent = now - last
    if silent < lost_after_s:
        return ""
    return f"no /diagnosis from the engine for {silent:.1f} s"
