"""The observer host: every observer of a model in one process (one ObserverBank).

It keeps the current verdict of every atom, so that a transport can publish the whole
observation set (one status per literal) whenever a verdict changes and again
periodically for late subscribers, and logs each change with its time.

**Two clocks.**  The observers run on seconds since the host started (small numbers keep
their running sums exact); every time the host shows, in its log and in ``since`` on
``/observations``, is wall-clock seconds since 1970, as the engine's and the repairer's
logs are: the host's own time plus :attr:`ObserverHost.epoch`, which the sample loop
refreshes at each tick.

**Starvation.**  The host times each message when its callback runs.  When the process does
not get the CPU, messages wait and then arrive in a clump, and a topic looks silent or
bursty although its publisher is fine.  The host watches its own sample loop
(:class:`HostLoop`, 10 Hz): it is starved from the moment a tick is overdue by more than
``starved_s`` (0.1 s), seen by the late tick itself or by any message callback that runs
before it, until ticks have come on time for ``recover_s`` (1 s).  While it is starved the
observers that judge time count no violation and report no new negative verdict
(:meth:`rac.observe.ObserverBank.starved`); the beginning and the end are logged.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace

from rac.logic import Atom
from rac.observe import ChannelState, DeviceStatus, Event, Message, ObserverBank, Verdict
from rac.observe.dobs import names_device, violations_first
from rac.passes.observers import ObserverSpec, TopicSource
from rac.runtime.cost import CostMeter, HostCost
from rac.runtime.placement import PlacementView
from rac.runtime.procs import ProcessProbe
from rac.runtime.sources import SourceCheck, device_reporters, node_name
from rac.runtime.status import Row, literal_row, row_channel, unknown_row


class ObserverHost:
    """Thread-safe: a transport may feed it from several callback threads."""

    def __init__(
        self,
        specs: Iterable[ObserverSpec],
        clock: Callable[[], float] | None = None,
        sources: Mapping[str, TopicSource] | None = None,
    ) -> None:
        self.specs = tuple(specs)
        self.bank = ObserverBank(self.specs)
        # Whose messages count (rac.runtime.sources); what does not is handed to
        # ``refuse(source, topic, reason)``, which the transport points at its Trust.
        self.check = SourceCheck(sources)
        self.reporters = device_reporters(self.specs)
        self.refuse: Callable[[str, str, str], None] = lambda source, topic, reason: None
        # Topics whose observers are suspended: a transport drops their messages unread.
        self.suspended: set[str] = set()
        # Seconds since the host started: small numbers keep the observers' running sums
        # (regressions over time) accurate, which epoch seconds (~1.8e9) would not.
        start = time.monotonic()
        self.clock = clock or (lambda: time.monotonic() - start)
        self.epoch = time.time() - self.clock()  # wall-clock time = host time + epoch
        self.owner: dict[Atom, str] = {a: s.name for s in self.specs for a in s.atoms}
        self.current: dict[Atom, Verdict] = {}
        self.changes: list[Verdict] = []  # since the last ``take_changes``
        self.dirty: set[Atom] = set()  # atoms whose row changed since ``take_dirty``
        self.errors: list[str] = []  # observers that failed on an event, for the log
        self.notes: list[str] = []  # starvation began or ended, for the log
        self.starved = False
        self.schedule: Schedule | None = None  # the sample loop's, once it ticks
        self._last_tick: float | None = None
        self._on_time_since: float | None = None
        self._starved_since = 0.0
        self.extra: dict[Atom, tuple[tuple[str, str], ...]] = {}  # more values of a row
        self.withdrawn: dict[Atom, float] = {}  # atoms made unknown, since when
        self._withheld: dict[Atom, Verdict] = {}  # the last verdict of a withdrawn atom
        self._suspended_at: dict[str, float] = {}  # topic -> when its observers paused
        # The host's node name, on every row (value "host"): the engine tells hosts apart
        # by it and makes a silent host's atoms unknown (rac.runtime.hosts).
        self.source = ""
        self._lock = threading.Lock()
        self._last_t = float("-inf")
        self.received = 0  # messages fed so far (the host's cost report)
        # Messages fed from reports of them (ROS 1's topic statistics), never received,
        # and how many topics are taken so now (None: the transport takes none so).
        self.reported = 0
        self.statistics_topics: Callable[[], int] | None = None
        # The CPU time of the thread that receives and feeds the messages, where a transport
        # has one (ROS 1's lean receiver): the per-message path, apart from the sampling.
        self.path_cpu: Callable[[], float] | None = None

    @property
    def atoms(self) -> tuple[Atom, ...]:
        return tuple(self.owner)

    def wall(self, t: float) -> float:
        """Host time ``t`` as wall-clock seconds since 1970."""
        return t + self.epoch

    def _now(self) -> float:
        # Every stream must see non-decreasing times, whatever thread delivers the event.
        self._last_t = max(self._last_t, self.clock())
        return self._last_t

    def message(self, topic: str, values: Mapping[str, float], stamp: float | None = None) -> None:
        """A message received now; ``stamp`` its header stamp (None: none)."""
        with self._lock:
            t = self._arrival(1)
            self._feed(Message(t, topic, values, stamp))

    def _arrival(self, count: int, reported: bool = False) -> float:
        """Now, for ``count`` messages that came (``reported``: that a report counted): a
        message that comes while the sample tick is overdue starts a starvation (the
        module's docstring).  Holds the lock."""
        t = self._now()
        schedule = self.schedule
        if schedule is not None and not self.starved and self._last_tick is not None:
            late = t - self._last_tick - schedule.period_s
            if late > schedule.starved_s:
                self._starve(t, late, "a message came")
        if reported:
            self.reported += count
        else:
            self.received += count
        return t

    def messages(
        self,
        topic: str,
        count: int,
        stamps: Sequence[float | None] = (),
        values: Sequence[Mapping[str, float]] = (),
        seqs: Sequence[int | None] = (),
        reported: bool = False,
    ) -> None:
        """``count`` messages of ``topic`` received together now (a transport that reads
        what came on a connection in one pass): as many :meth:`message` calls, for one
        lock and one routing; ``stamps``, ``values`` and ``seqs`` each message's, or
        empty.  ``reported``: messages a subscriber's report counted, which the host did
        not receive (rac.runtime.topic_statistics)."""
        with self._lock:
            t = self._arrival(count, reported)
            try:
                self._keep(self.bank.feed_messages(t, topic, count, stamps, values, seqs))
            except (ArithmeticError, ValueError) as err:  # one bad batch must not stop the host
                self.errors.append(f"{count} messages of {topic} at t={self.wall(t):.3f}: {err}")

    def tick(self, wall: float, schedule: Schedule) -> None:
        """The sample loop's tick at wall-clock time ``wall``: the epoch, and whether the
        host is starved (see the module's docstring)."""
        with self._lock:
            self.schedule = schedule
            t = self._now()
            self.epoch = wall - self.clock()
            last, self._last_tick = self._last_tick, t
            if last is None:
                return
            late = t - last - schedule.period_s
            if late > schedule.starved_s:
                self._on_time_since = None
                if not self.starved:
                    self._starve(t, late, "the sample tick came")
                return
            if not self.starved:
                return
            if self._on_time_since is None:
                self._on_time_since = last
            if t - self._on_time_since >= schedule.recover_s:
                self.starved = False
                self._keep(self.bank.starved(t, False))
                self.notes.append(
                    f"t={self.wall(t):.3f} observer host no longer starved, after "
                    f"{t - self._starved_since:.2f} s: timing verdicts resume once "
                    "late arrivals have left their windows"
                )

    def _starve(self, t: float, late: float, seen: str) -> None:
        self.starved = True
        self._starved_since = t
        self._on_time_since = None
        self._keep(self.bank.starved(t, True))
        self.notes.append(
            f"t={self.wall(t):.3f} observer host starved: {seen} {late:.3f} s after the "
            "sample tick was due; timing verdicts held (no new not_ok)"
        )

    def feed(self, events: Iterable[Event]) -> None:
        """Events of their own streams (node samples, statuses, channels), already timed."""
        with self._lock:
            for e in events:
                self._feed(e)

    def device_rows(self, rows: Iterable[Row], source: str | None = None) -> None:
        """A ``/diagnostics`` array (DObs) published by node ``source`` (None: unknown, as
        on ROS 2): a status of a device counts only from the nodes the model has report
        it; another node's status of it is refused."""
        t = self.clock()
        statuses = [DeviceStatus(t, r.name, r.hardware_id, r.level) for r in rows]
        if source is not None and self.reporters:
            statuses = [s for s in statuses if self._reported_by(s, source)]
        # One check per array at its worst level (DObs): violations first.
        self.feed(violations_first(statuses))

    def _reported_by(self, status: DeviceStatus, source: str) -> bool:
        sender = node_name(source)
        for device, reporters in self.reporters.items():
            if names_device(status, device) and reporters and sender not in reporters:
                shown = ", ".join(sorted(reporters))
                self.refuse(
                    source,
                    "/diagnostics",
                    f"a status of device {device}, which the model has {shown} report",
                )
                return False
        return True

    def suspend_topic(self, topic: str, why: str) -> None:
        """``topic``'s messages cannot be told from a stranger's: its observers get none,
        and what they report is unknown until :meth:`resume_topic`."""
        with self._lock:
            if self.bank.suspended(topic):
                return
            atoms = self.bank.suspend(topic)
            self.suspended.add(topic)
            self._suspended_at[topic] = self._now()
            self.notes.append(
                f"t={self.wall(self._now()):.3f} observers of {topic} suspended ({why}): "
                f"{len(atoms)} atoms unknown"
            )
        self.withdraw(atoms)

    def resume_topic(self, topic: str) -> None:
        """``topic``'s observers are fed again: those that time its messages afresh; after
        a pause shorter than KEEP_PAUSED_S (a robot's node restarting, a stranger's
        message that came and went), those that judge its values from where they were."""
        with self._lock:
            if not self.bank.suspended(topic):
                return
            now = self._now()
            paused = now - self._suspended_at.pop(topic, now)
            kept = self.bank.resume(topic, keep_values=paused <= KEEP_PAUSED_S)
            self.suspended.discard(topic)
            self.notes.append(
                f"t={self.wall(now):.3f} observers of {topic} resumed after {paused:.2f} s "
                f"({'timing afresh, values kept' if kept else 'afresh'}): only the model's "
                "publishers publish it again"
            )
        self.restore(kept)

    def retime(self, topic: str) -> None:
        """``topic``'s frequency observers start afresh (ObserverBank.retime)."""
        with self._lock:
            self.bank.retime(topic)

    def channel_rows(self, rows: Iterable[Row]) -> None:
        """A ``/board_measurements`` array (HObs)."""
        t = self.clock()
        states = [row_channel(r, t) for r in rows]
        self.feed([s for s in states if isinstance(s, ChannelState)])

    def advance(self) -> None:
        with self._lock:
            self._keep(self.bank.advance(self._now()))

    def _feed(self, event: Event) -> None:
        try:
            self._keep(self.bank.feed(event))
        except (ArithmeticError, ValueError) as err:  # one bad event must not stop the host
            self.errors.append(f"{type(event).__name__} at t={self.wall(event.t):.3f}: {err}")

    def _keep(self, verdicts: list[Verdict]) -> None:
        for v in verdicts:
            self.current[v.atom] = v
            self.withdrawn.pop(v.atom, None)
            self._withheld.pop(v.atom, None)
            self.changes.append(v)
            self.dirty.add(v.atom)

    def withdraw(self, atoms: Iterable[Atom]) -> list[Atom]:
        """Make atoms unknown (their last verdict no longer holds); the ones that had one."""
        out = []
        with self._lock:
            t = self._now()
            for atom in atoms:
                last = self.current.pop(atom, None)
                if last is not None:
                    self._withheld[atom] = last
                if last is not None or atom not in self.withdrawn:
                    self.withdrawn[atom] = t
                    self.dirty.add(atom)
                    out.append(atom)
        return out

    def restore(self, atoms: Iterable[Atom]) -> list[Verdict]:
        """Withdrawn atoms that can be judged again: their observer's last verdict holds
        again, from now (an observer reports only changes, so it would never say it again).
        The verdicts restored; an atom without one stays unknown until its first."""
        out = []
        with self._lock:
            t = self._now()
            for atom in atoms:
                last = self._withheld.pop(atom, None)
                if last is not None and self.withdrawn.pop(atom, None) is not None:
                    v = replace(last, t=t)
                    self.current[atom] = v
                    self.changes.append(v)
                    out.append(v)
        return out

    def annotate(self, atom: Atom, values: tuple[tuple[str, str], ...]) -> None:
        with self._lock:
            self.extra[atom] = values
            self.dirty.add(atom)

    def take_changes(self) -> list[Verdict]:
        with self._lock:
            out, self.changes = self.changes, []
            return out

    def take_errors(self) -> list[str]:
        with self._lock:
            out, self.errors = self.errors, []
            return out

    def take_notes(self) -> list[str]:
        with self._lock:
            out, self.notes = self.notes, []
            return out

    def take_dirty(self) -> set[Atom]:
        """The atoms whose row changed since the last call (a verdict, a withdrawal, the
        values of its row)."""
        with self._lock:
            out, self.dirty = self.dirty, set()
            return out

    def rows(self, only: set[Atom] | None = None) -> tuple[Row, ...]:
        """One status per current literal, sorted by atom; ``only``: of those atoms alone."""
        with self._lock:
            current = (
                self.current
                if only is None
                else {a: self.current[a] for a in only if a in self.current}
            )
            verdicts = sorted(current.values(), key=lambda v: v.atom)
            epoch = self.epoch
            extra = dict(self.extra)
            gone = sorted((a, t) for a, t in self.withdrawn.items() if only is None or a in only)
        keyed = [
            (
                v.atom,
                literal_row(v, self.owner.get(v.atom, ""), v.t + epoch, extra.get(v.atom, ())),
            )
            for v in verdicts
        ]
        keyed.extend((a, unknown_row(a, self.owner.get(a, ""), t + epoch)) for a, t in gone)
        rows = (
            [row for _, row in sorted(keyed, key=lambda p: p[0])]
            if gone
            else [row for _, row in keyed]
        )
        if self.source:
            rows = [replace(r, values=(*r.values, ("host", self.source))) for r in rows]
        return tuple(rows)

    def all_ok(self) -> bool:
        """Every atom reported, and positively."""
        with self._lock:
            return len(self.current) == len(self.owner) and all(
                v.positive for v in self.current.values()
            )


def change_line(v: Verdict, observer: str, epoch: float = 0.0) -> str:
    """A log line for one verdict change, greppable: ``t=… observation not_ok(pose) …``,
    ``t`` wall-clock seconds (the verdict's host time plus ``epoch``)."""
    return f"t={v.t + epoch:.3f} observation {v} (by {observer})"


@dataclass(frozen=True, slots=True)
class Schedule:
    """The sample loop's period, and when the host counts as starved (module docstring)."""

    period_s: float = 0.1
    starved_s: float = 0.1  # a tick overdue by more than this: starved
    recover_s: float = 1.0  # ticks on time for this long: no longer starved


@dataclass(frozen=True, slots=True)
class HostStep:
    lines: tuple[str, ...]  # verdict changes, for the log
    warnings: tuple[str, ...]  # observers that failed
    rows: tuple[Row, ...] | None  # the observation set to publish now (None: nothing)


# A value observer paused this long or less goes on from its state when its topic resumes.
KEEP_PAUSED_S = 10.0


class HostLoop:
    """One sample period of the observer host node: whether the host is starved, node and
    property samples, the observers' clocks, what changed, and whether to publish (on a
    change, and every ``republish_s`` for late subscribers).  The transport calls
    :meth:`step` every ``schedule.period_s`` with the wall-clock time."""

    def __init__(
        self,
        host: ObserverHost,
        probe: ProcessProbe,
        republish_s: float = 1.0,
        schedule: Schedule | None = None,
    ) -> None:
        self.host, self.probe, self.republish_s = host, probe, republish_s
        self.schedule = schedule or Schedule()
        self.placement = PlacementView(host.specs)
        self._last_publish = float("-inf")
        self.cost = CostMeter(host)
        self.cost_reported: HostCost | None = None  # the last period that did not keep up

    def _placements(self) -> list[str]:
        """How each node whose placement changed is watched now: logged, on its
        ``running`` row, its unmeasurable atoms withdrawn (its properties without a proven
        process; its ``running`` too while that is unknown) and the others restored."""
        host, view, out = self.host, self.placement, []
        for node, found in self.probe.take_placements():
            out.append(view.line(host.clock() + host.epoch, node, found))
            running = view.running.get(node)
            if running is not None:
                host.annotate(running, view.values(node, found))
            why = "no answer" if found.unknown else "no process"
            for atom in host.withdraw(view.withdrawn(node, found)):
                wall = host.clock() + host.epoch
                out.append(f"t={wall:.3f} observation unknown {atom} ({why})")
            host.restore(view.measurable(node, found))  # logged as verdict changes
        return out

    def step(self, now: float) -> HostStep:
        host = self.host
        host.tick(now, self.schedule)
        host.feed(self.probe.sample(host.clock()))
        placed = self._placements()
        host.advance()
        changes = host.take_changes()
        lines = host.take_notes()
        epoch = host.epoch
        lines += placed
        lines += [change_line(v, host.owner.get(v.atom, ""), epoch) for v in changes]
        cost = self.cost.tick(now)
        if cost is not None:
            was = self.cost_reported
            if not cost.keeping_up or was is not None:
                lines.append(f"t={now:.3f} observer host load: {cost.text()}")
            if not cost.keeping_up and (was is None or was.keeping_up):
                lines.append(
                    f"t={now:.3f} observer host cannot keep up: {cost.text()}; messages "
                    "wait and arrive in clumps, so its verdicts come late"
                )
            self.cost_reported = cost if not cost.keeping_up else None
        warnings = tuple(f"an observer failed on {e}" for e in host.take_errors()[:5])
        # The rows that changed as soon as they do; every row every ``republish_s``, for
        # late subscribers and as the host's heartbeat.  A receiver merges what it gets
        # (docs/runtime.md, /observations): a model of 10,000 observers does not send
        # 10,000 rows ten times a second.
        rows = None
        dirty = host.take_dirty()
        if now - self._last_publish >= self.republish_s:
            rows = host.rows()
            self._last_publish = now
        elif dirty:
            rows = host.rows(dirty)
        return HostStep(tuple(lines), warnings, rows)


def ticks(
    period_s: float,
    running: Callable[[], bool],
    clock: Callable[[], float] = time.time,
    sleep: Callable[[float], None] = time.sleep,
) -> Iterator[float]:
    """The sample loop's pace: the clock's time once every ``period_s`` while ``running()``.
    A tick that comes late does not make the next ones come early to catch up (a starved
    host would otherwise run a burst of ticks): the schedule starts again from now."""
    next_tick = clock()
    while running():
        yield clock()
        next_tick += period_s
        delay = next_tick - clock()
        if delay > 0:
            sleep(delay)
        else:
            next_tick = clock()
