"""The observer host's clocks: starvation of its own sample loop, and wall-clock times in
its log lines and on /observations."""

from __future__ import annotations

import pytest

from rac.logic import Atom
from rac.passes.observers import ObserverSpec
from rac.runtime.host import HostLoop, HostStep, ObserverHost, Schedule, ticks
from rac.runtime.procs import ProcessProbe

WALL0 = 1.78e9  # the wall clock when the host's own clock reads 0
RATE = 100.0
SPEC = ObserverSpec(
    "GObs",
    "x_gobs",
    (
        ("topic", "/x"),
        ("delta", 1 / RATE),
        ("dev", 1 / (0.9 * RATE) - 1 / RATE),
        ("ws", 10 / RATE),
        ("mismatch_th", 5),
    ),
    (Atom("ok", ("x",)),),
)


class Robot:
    """A 100 Hz topic and the host's 10 Hz sample loop on a fake clock."""

    def __init__(self, ticking: bool = True) -> None:
        self.now = 0.0
        self.host = ObserverHost([SPEC], clock=lambda: self.now)
        self.loop = HostLoop(self.host, ProcessProbe([], lambda _: None), schedule=Schedule())
        self.ticking = ticking
        self.lines: list[str] = []
        self.steps: list[HostStep] = []
        self._next_tick = 0.0
        self._k = 0

    def run(self, until: float, publish: bool = True) -> None:
        """Messages every 10 ms (stamped by the publisher) and ticks every 0.1 s."""
        while True:
            t_msg = self._k / RATE
            t = min(t_msg, self._next_tick)
            if t > until:
                return
            self.now = t
            if t == self._next_tick:
                if self.ticking:
                    step = self.loop.step(WALL0 + t)
                    self.steps.append(step)
                    self.lines += step.lines
                self._next_tick = round(self._next_tick + 0.1, 9)
            else:
                if publish:
                    self.host.message("/x", {}, WALL0 + t_msg)
                self._k += 1

    def stall(self, seconds: float) -> None:
        """The process gets no CPU: then the messages that waited arrive in a clump."""
        stamps = []
        end = self.now + seconds
        while self._k / RATE <= end:
            stamps.append(WALL0 + self._k / RATE)
            self._k += 1
        self._next_tick = round(self._next_tick + seconds - seconds % 0.1, 9)
        self.now = end
        for stamp in stamps:
            self.host.message("/x", {}, stamp)


def test_a_stalled_host_holds_its_verdicts_and_says_so() -> None:
    robot = Robot()
    robot.run(10.0)
    assert robot.host.all_ok()
    robot.stall(2.0)  # a message callback sees the tick 1.9 s overdue first
    robot.run(20.0)
    assert robot.host.all_ok()
    starved = [line for line in robot.lines if "starved" in line]
    assert len(starved) == 2, robot.lines
    assert starved[0].startswith(f"t={WALL0 + 12.0:.3f} observer host starved: a message came")
    assert "no longer starved" in starved[1]
    assert not [line for line in robot.lines if "observation not_ok" in line]


def test_the_same_stall_reads_not_ok_without_the_watch() -> None:
    # No sample loop: nobody knows the host was starved, and the 2 s the messages waited
    # read as a silence.
    robot = Robot(ticking=False)
    robot.run(10.0)
    robot.stall(2.0)
    assert [str(v) for v in robot.host.take_changes()] == ["ok(x)", "not_ok(x)"]


def test_a_late_tick_starts_a_starvation_and_a_stopped_topic_still_shows_after_it() -> None:
    robot = Robot()
    robot.run(5.0)
    robot.now = 5.5  # the tick of 5.1 comes at 5.5: overdue by 0.4 s, no message between
    robot._next_tick = 5.5
    robot.run(5.5, publish=False)
    assert any("starved: the sample tick came 0.400 s" in line for line in robot.lines)
    robot.run(9.0, publish=False)  # the topic stopped at 5.0: not_ok once the host is fed
    assert "no longer starved" in " ".join(robot.lines)
    assert not robot.host.all_ok()
    (line,) = [line for line in robot.lines if "observation not_ok(x)" in line]
    # Silence is timed from the end of the starvation (1 s of ticks on time after 5.5).
    t = float(line.split()[0].removeprefix("t=")) - WALL0
    assert 6.5 + 0.5 < t <= 6.5 + 0.5 + 0.06 + 0.5 + 0.01


def test_log_lines_and_since_are_wall_clock_times() -> None:
    robot = Robot()
    robot.run(2.0)
    (line,) = [line for line in robot.lines if "observation" in line]
    verdict = robot.host.current[SPEC.atoms[0]]
    assert line == f"t={WALL0 + verdict.t:.3f} observation ok(x) (by x_gobs)"
    (row,) = robot.host.rows()
    assert row.value("since") == f"{WALL0 + verdict.t:.3f}"


def test_a_late_tick_does_not_make_the_next_ones_come_early() -> None:
    # A host starved for 0.35 s must not then run three ticks back to back to catch up.
    now, slept = [0.0], []

    def sleep(s: float) -> None:
        slept.append(s)
        now[0] += s

    times: list[float] = []
    for t in ticks(0.1, lambda: len(times) < 5, clock=lambda: now[0], sleep=sleep):
        times.append(t)
        if len(times) == 2:
            now[0] += 0.35  # this tick's work took 0.35 s
    assert times == pytest.approx([0.0, 0.1, 0.45, 0.55, 0.65])
    assert all(s > 0 for s in slept)


def test_the_host_measures_its_cost_and_says_when_it_cannot_keep_up() -> None:
    from rac.runtime.cost import CostMeter

    host = ObserverHost([])
    cpu = [0.0]
    meter = CostMeter(host, period_s=10.0, cpu=lambda: cpu[0])
    assert meter.tick(0.0) is None
    host.received = 50_000
    cpu[0] = 0.5
    assert meter.tick(5.0) is None  # not a whole period yet
    cost = meter.tick(10.0)
    assert cost is not None
    assert cost.rate == pytest.approx(5000.0)
    assert cost.cpu_percent == pytest.approx(5.0)
    assert cost.us_per_message == pytest.approx(10.0)
    assert cost.keeping_up and cost.row("racc_observer").level == 0
    host.received += 10_000
    cpu[0] += 9.0  # 90 % of a core
    busy = meter.tick(20.0)
    assert busy is not None and not busy.keeping_up
    row = busy.row("racc_observer")
    assert row.level == 1 and row.message.startswith("cannot keep up: 1000 messages/s, 90.0 %")
    assert row.name == "racc_observer: load"


def test_the_cost_says_how_many_topics_reports_stand_for_and_counts_them_apart() -> None:
    from rac.runtime.cost import CostMeter

    host = ObserverHost([SPEC], clock=lambda: 1.0)
    cpu = [0.0]
    meter = CostMeter(host, period_s=10.0, cpu=lambda: cpu[0])
    assert meter.tick(0.0) is None
    host.messages("/x", 300)
    host.messages("/x", 7000, reported=True)
    host.statistics_topics = lambda: 98
    cpu[0] = 0.1
    cost = meter.tick(10.0)
    assert cost is not None and cost.rate == pytest.approx(30.0)
    row = cost.row("racc_observer")
    assert row.message.endswith(
        "; 98 topics from /statistics (700 messages/s reported, not received)"
    )
    assert ("statistics_topics", "98") in row.values and ("reported_per_s", "700.0") in row.values
    host.statistics_topics = None
    plain = meter.tick(20.0)
    assert plain is not None and "statistics" not in plain.row("racc_observer").message


def test_a_change_publishes_its_rows_and_every_row_goes_out_once_a_second() -> None:
    """/observations carries the rows that changed as soon as they do, and every row every
    republish_s (a model of 10,000 observers must not send 10,000 rows at each change)."""
    other = ObserverSpec(
        "GObs",
        "y_gobs",
        (("topic", "/y"), ("delta", 0.1), ("mismatch_th", 5)),
        (Atom("ok", ("y",)),),
    )
    now = [0.0]
    host = ObserverHost([SPEC, other], clock=lambda: now[0])
    loop = HostLoop(host, ProcessProbe([], lambda _: None), republish_s=1.0)
    published: list[tuple[float, list[str]]] = []
    for k in range(400):  # 4 s: /x at 100 Hz throughout, /y at 10 Hz until 2 s
        now[0] = k / 100
        host.message("/x", {})
        if k % 10 == 0 and k < 200:
            host.message("/y", {})
        if k % 10 == 0:
            step = loop.step(WALL0 + now[0])
            if step.rows is not None:
                published.append((now[0], [r.message for r in step.rows]))
    # every row each second (none before the first verdicts); the first verdicts as they
    # come; then only the row that changed
    assert [t for t, _ in published] == [0.0, 1.0, 1.1, 2.0, 3.0, 3.4], published
    assert dict(published)[3.0] == ["ok(x)", "ok(y)"]
    assert dict(published)[3.4] == ["not_ok(y)"]
