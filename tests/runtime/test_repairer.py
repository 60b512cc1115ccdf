"""The repair executor's rules (rac.runtime.repairer), each on a fake clock and a fake robot:
confirmation, a diagnosis read again before every step, the bring-up grace, the restart
budget with its back-off, the robot's shutdown, killing a node that does not stop, time-outs
that run from the request, requests that hang, and the advisory and dry-run modes."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable
from pathlib import Path

import pytest

from rac.diagnosis import Theory
from rac.errors import Diagnostic, RacError
from rac.load.files import load_model
from rac.load.theory import load_theory
from rac.logic import Atom
from rac.observe import Verdict
from rac.pipeline import compile_model
from rac.runtime.repairer import LogEntry, Mode, RepairExecutor, Settings, State
from rac.targets import EmitOptions, emit_all

ROOT = Path(__file__).resolve().parents[2]
NODES = (
    "hector_mapping",
    "hokuyo_node",
    "imu_node",
    "jaguar_node",
    "jaguar_teleop_node",
    "joy_node",
    "laser_alignment_control",
    "laser_alignment_node",
    "rviz",
)


@pytest.fixture(scope="module")
def theory(tmp_path_factory: pytest.TempPathFactory) -> Theory:
    out = tmp_path_factory.mktemp("tedusar")
    compiled = compile_model(load_model(ROOT / "models" / "tedusar.ram"))
    (out / "model.yaml").write_text(emit_all(compiled, EmitOptions())["model.yaml"], "utf-8")
    return load_theory(str(out / "model.yaml"))


class Clock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


class Robot:
    """A fake robot: a request changes what the executor observes (unless the robot is
    ``frozen`` for stops, or ``broken`` for everything), after ``call_s`` of the clock."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self.calls: list[tuple[str, str, float]] = []
        self.executor: RepairExecutor | None = None
        self.frozen = False  # stop_node does nothing (SIGSTOP); kill_node works
        self.broken = False  # no request takes effect
        self.call_s = 0.0  # how long a call blocks (on the fake clock)
        self.fail_first = False  # the first call raises RacError

    def _do(self, action: str, target: str, atom: Atom | None, positive: bool) -> str | None:
        self.calls.append((action, target, self.clock.t))
        self.clock.t += self.call_s
        if self.fail_first:
            self.fail_first = False
            raise RacError([Diagnostic("RAC111", f"cannot {action} {target}")])
        if atom is not None and not self.broken and self.executor is not None:
            self.executor.observe(Verdict(self.clock.t, atom, positive))
        return None

    def stop_node(self, node: str) -> str | None:
        atom = None if self.frozen else Atom("running", (node,))
        return self._do("stop_node", node, atom, False)

    def kill_node(self, node: str) -> str | None:
        return self._do("kill_node", node, Atom("running", (node,)), False)

    def start_node(self, node: str) -> str | None:
        self._do("start_node", node, Atom("running", (node,)), True)
        return "started detached as pid 4242 (stop it with 'kill 4242')"

    def switch(self, device: str, on: bool) -> str | None:
        return self._do("power_up" if on else "shutdown", device, Atom("on", (device,)), on)

    def actions(self) -> list[tuple[str, str]]:
        return [(a, t) for a, t, _ in self.calls]


class Rig:
    def __init__(self, theory: Theory, **settings: object) -> None:
        self.clock = Clock()
        self.robot = Robot(self.clock)
        self.log: list[LogEntry] = []
        defaults: dict[str, object] = dict(step_timeout_s=5.0, verify_timeout_s=10.0)
        defaults.update(settings)
        self.ex = RepairExecutor(
            theory,
            "tedusar",
            self.robot,
            self.log.append,
            clock=self.clock,
            settings=Settings(**defaults),  # type: ignore[arg-type]
        )
        self.robot.executor = self.ex

    def observe(self, text: str, positive: bool = True) -> None:
        predicate, _, rest = text.partition("(")
        args = tuple(rest.rstrip(")").split(","))
        self.ex.observe(Verdict(self.clock.t, Atom(predicate, args), positive))

    def healthy(self, nodes: Iterable[str] = NODES) -> None:
        for node in nodes:
            self.observe(f"running({node})")
        self.ex.diagnosis(())

    def crash(self, *nodes: str) -> None:
        for node in nodes:
            self.observe(f"running({node})", False)
        self.ex.diagnosis((tuple(sorted(nodes)),) if nodes else ())

    def run(self, seconds: float, dt: float = 0.1) -> None:
        end = self.clock.t + seconds
        while self.clock.t < end - 1e-9:
            self.clock.t = round(self.clock.t + dt, 6)
            self.ex.tick()

    def until(self, what: str, seconds: float, dt: float = 0.1) -> float | None:
        """Tick until a log entry's action is ``what``; its time (None: not within)."""
        end = self.clock.t + seconds
        while self.clock.t < end - 1e-9:
            self.clock.t = round(self.clock.t + dt, 6)
            before = len(self.log)
            self.ex.tick()
            if any(e.action == what for e in self.log[before:]):
                return self.clock.t
        return None

    def entries(self, action: str) -> list[LogEntry]:
        return [e for e in self.log if e.action == action]


def test_a_diagnosis_must_stand_the_confirmation_time(theory: Theory) -> None:
    rig = Rig(theory)
    rig.healthy()
    start = rig.clock.t
    rig.crash("jaguar_node")
    planned = rig.until("plan", 5.0)
    assert planned is not None and planned - start >= 2.0, planned
    rig.run(0.3)
    assert rig.robot.actions() == [("start_node", "jaguar_node")]


def test_a_diagnosis_that_clears_before_the_confirmation_time_is_not_repaired(
    theory: Theory,
) -> None:
    rig = Rig(theory)
    rig.healthy()
    rig.crash("jaguar_node")
    rig.run(1.0)
    rig.healthy()  # the fault was a blip
    rig.run(10.0)
    assert rig.robot.calls == [] and rig.entries("plan") == []


def test_a_diagnosis_that_clears_after_the_plan_is_made_aborts_it(theory: Theory) -> None:
    # The measured failure: diagnosis at 500.8 s, cleared at 501.5 s, plan executed at
    # 501.8 s.  The first step goes in the tick after the plan, once the inputs that came
    # in while planning are read: the cleared diagnosis aborts it.
    rig = Rig(theory)
    rig.healthy()
    rig.crash("jaguar_node")
    assert rig.until("plan", 5.0) is not None
    rig.ex.diagnosis(())  # arrived while the planner ran
    rig.run(1.0)
    assert rig.robot.calls == []
    (abort,) = rig.entries("abort")
    assert "the diagnosis cleared" in abort.message and abort.level == 1
    assert rig.ex.state is State.IDLE


def test_before_every_step_the_target_must_still_be_diagnosed(theory: Theory) -> None:
    rig = Rig(theory)
    rig.healthy()
    rig.crash("hokuyo_node", "imu_node")
    assert rig.until("plan", 5.0) is not None
    rig.run(0.2)  # the first step is done (the fake robot starts a node at once)
    assert len(rig.robot.calls) == 1
    rig.healthy()  # the other node was a false alarm: the diagnosis cleared
    rig.run(5.0)
    assert len(rig.robot.calls) == 1, rig.robot.calls
    assert "the diagnosis cleared" in rig.entries("abort")[0].message


def test_a_cleared_diagnosis_still_lets_the_plan_restart_what_it_stopped(
    theory: Theory,
) -> None:
    # /scan is silent while hokuyo_node runs: stop it, then start it.  The diagnosis
    # clearing once it is stopped must not leave the node stopped.
    rig = Rig(theory)
    rig.healthy()
    rig.observe("ok(scan)", False)
    rig.ex.diagnosis((("hokuyo_node",),))
    assert rig.until("plan", 5.0) is not None
    rig.run(0.2)
    assert rig.robot.actions() == [("stop_node", "hokuyo_node")]
    rig.ex.diagnosis(())
    rig.run(1.0)
    assert rig.robot.actions() == [("stop_node", "hokuyo_node"), ("start_node", "hokuyo_node")]


def test_a_node_never_seen_running_waits_out_the_bring_up_grace(theory: Theory) -> None:
    # At bring-up on ROS 2 the repairer "repaired" nodes that had not started yet.
    rig = Rig(theory, startup_grace_s=30.0)
    began = rig.clock.t
    rig.healthy([n for n in NODES if n != "joy_node"])
    rig.crash("joy_node")
    rig.run(20.0)
    assert rig.robot.calls == []
    (hold,) = rig.entries("hold")
    assert "joy_node has not been seen running yet (bring-up grace" in hold.message
    planned = rig.until("plan", 20.0)
    assert planned is not None and planned - began >= 30.0
    rig.run(0.3)
    assert rig.robot.actions() == [("start_node", "joy_node")]


def test_the_grace_runs_from_when_the_node_first_shows(theory: Theory) -> None:
    rig = Rig(theory, startup_grace_s=30.0)
    rig.healthy([n for n in NODES if n != "joy_node"])
    rig.run(25.0)
    first_heard = rig.clock.t
    rig.crash("joy_node")  # the observer reports it only now
    planned = rig.until("plan", 40.0)
    assert planned is not None and planned - first_heard >= 30.0


def test_a_node_seen_running_is_repaired_without_grace(theory: Theory) -> None:
    rig = Rig(theory, startup_grace_s=30.0)
    rig.healthy()
    rig.crash("joy_node")
    assert rig.until("plan", 3.0) is not None


def _crash_and_repair(rig: Rig, node: str) -> None:
    rig.crash(node)
    for _ in range(400):  # at most 40 s for the plan, its step and its verification
        rig.run(0.1)
        if rig.ex.state is State.VERIFYING:
            rig.run(0.1)
            rig.healthy()  # the engine's next message: no fault
            rig.run(0.2)
            assert rig.ex.state is State.IDLE  # type: ignore[comparison-overlap]  # mypy keeps the narrowing across the calls above
            return


@pytest.mark.slow
def test_repairs_of_one_component_back_off_then_escalate_on_its_budget(theory: Theory) -> None:
    rig = Rig(theory, budget=3, budget_window_s=600.0, backoff_s=10.0)
    rig.healthy()
    starts = []
    for _ in range(3):
        _crash_and_repair(rig, "jaguar_node")
        starts.append(rig.robot.calls[-1][2])
    # The back-off doubles: 10 s after the first repair ended, 20 s after the second.
    assert starts[1] - starts[0] >= 10.0 and starts[2] - starts[1] >= 20.0, starts
    assert any("back-off until" in e.message for e in rig.entries("hold"))
    rig.crash("jaguar_node")
    rig.run(60.0)
    assert len(rig.robot.calls) == 3  # the fourth repair is over the budget
    escalate = [e for e in rig.entries("escalate") if "budget" in e.message]
    assert len(escalate) == 1 and "RAC110" in escalate[0].message
    status = rig.ex.status("racc_repairer")
    assert status.level == 2 and "jaguar_node" in status.message
    assert "3/3 in 600 s" in status.value("budget jaguar_node")
    assert "escalated until" in status.value("budget jaguar_node")
    # Once the first repair leaves the window, racc acts on it again.
    rig.run(600.0 - (rig.clock.t - starts[0]) + 1.0, dt=1.0)
    rig.run(3.0)
    assert len(rig.robot.calls) == 4


@pytest.mark.slow
def test_two_healthy_nodes_alternating_stop_at_their_budgets(theory: Theory) -> None:
    # On false positives the repairer looped: 8 plans in 70 s alternating between two
    # healthy nodes, each restart "working".  Each node's budget ends it.
    rig = Rig(theory)
    rig.healthy()
    for k in range(60):
        node = ("imu_node", "hokuyo_node")[k % 2]
        rig.observe("ok(scan)" if node == "hokuyo_node" else "ok(imu_data)", False)
        rig.ex.diagnosis(((node,),))
        rig.run(3.0)
        rig.observe("ok(scan)" if node == "hokuyo_node" else "ok(imu_data)", True)
        rig.healthy()
        rig.run(3.0)
    plans = rig.entries("plan")
    assert len(plans) <= 6, [e.message for e in plans]
    escalated = {e.message.split()[1] for e in rig.entries("escalate") if "budget" in e.message}
    assert escalated == {"imu_node", "hokuyo_node"}


def test_nodes_stopping_together_are_a_shutdown_and_nothing_is_repaired(theory: Theory) -> None:
    # The robot was shut down before racc, and racc restarted the robot's nodes.
    rig = Rig(theory)
    rig.healthy()
    stopping = NODES[:6]
    for node in stopping:  # roslaunch stops its nodes one after the other
        rig.crash(*stopping[: stopping.index(node) + 1])
        rig.run(0.7)
    rig.run(30.0)
    assert rig.robot.calls == []
    (down,) = [e for e in rig.entries("robot") if "shutting down" in e.message]
    assert "of 9 nodes stopped together" in down.message
    # The robot comes back but for one node: it gets a bring-up grace, not a restart.
    rig.healthy([n for n in NODES if n != "rviz"])
    rig.crash("rviz")
    rig.run(10.0)
    assert any("the robot is back" in e.message for e in rig.entries("robot"))
    assert rig.robot.calls == []
    rig.run(30.0)
    assert rig.robot.actions() == [("start_node", "rviz")]


def test_two_nodes_crashing_together_are_repaired(theory: Theory) -> None:
    rig = Rig(theory)
    rig.healthy()
    rig.crash("imu_node")
    rig.run(0.5)
    rig.crash("imu_node", "jaguar_node")
    rig.run(10.0)
    started = sorted(rig.robot.actions())
    assert started == [("start_node", "imu_node"), ("start_node", "jaguar_node")]
    assert rig.entries("robot") == []


def test_without_the_master_nothing_is_repaired(theory: Theory) -> None:
    rig = Rig(theory)
    rig.healthy()
    rig.ex.middleware(False, "the ROS master is gone")
    rig.crash("jaguar_node")
    rig.run(10.0)
    assert rig.robot.calls == []
    assert [e.message for e in rig.entries("robot")] == [
        "the robot is shutting down (the ROS master is gone): repairing nothing"
    ]
    rig.ex.middleware(True)
    rig.run(0.1)
    assert "the robot is back" in rig.entries("robot")[-1].message


def test_a_node_that_does_not_stop_is_killed_after_the_step_timeout(theory: Theory) -> None:
    # A frozen (SIGSTOP) publisher: /scan is silent, hokuyo_node "runs".
    rig = Rig(theory, step_timeout_s=5.0)
    rig.robot.frozen = True
    rig.healthy()
    rig.observe("ok(scan)", False)
    rig.ex.diagnosis((("hokuyo_node",),))
    rig.run(12.0)
    assert rig.robot.actions()[:3] == [
        ("stop_node", "hokuyo_node"),
        ("kill_node", "hokuyo_node"),
        ("start_node", "hokuyo_node"),
    ]
    stop_t, kill_t = rig.robot.calls[0][2], rig.robot.calls[1][2]
    assert 5.0 <= kill_t - stop_t <= 5.2
    assert any("did not stop within 5 s; killing it" in e.message for e in rig.log)


def test_time_outs_and_reported_times_run_from_the_request(theory: Theory) -> None:
    # A call that blocked 17 s: the second attempt must still wait a full step time-out
    # after the request, and "observed after" must count from it.
    rig = Rig(theory, step_timeout_s=5.0)
    rig.healthy()
    rig.robot.frozen = True
    rig.robot.call_s = 17.0
    rig.observe("ok(scan)", False)
    rig.ex.diagnosis((("hokuyo_node",),))
    rig.run(3.0)
    (stop,) = [e for e in rig.entries("stop_node") if "requested" in e.message]
    assert "the call took 17.00 s" in stop.message
    rig.robot.call_s = 0.0
    rig.run(8.0)
    kill = rig.robot.calls[1]
    assert kill[0] == "kill_node" and kill[2] - stop.t >= 5.0 - 1e-6
    done = [e for e in rig.entries("stop_node") if e.message.startswith("done")]
    killed = next(e for e in rig.entries("stop_node") if "killed" in e.message)
    after = float(done[0].message.split("observed after ")[1].split(" s")[0])
    assert abs(after - (done[0].t - killed.t)) < 0.01


def test_a_failed_request_is_tried_again_after_a_full_step_timeout(theory: Theory) -> None:
    rig = Rig(theory, step_timeout_s=5.0)
    rig.healthy()
    rig.robot.fail_first = True
    rig.crash("jaguar_node")
    rig.run(10.0)
    first, second = rig.robot.calls[:2]
    assert second[2] - first[2] >= 5.0
    assert "attempt 1 failed" in rig.entries("start_node")[0].message


def test_a_request_that_hangs_does_not_stall_the_loop(theory: Theory) -> None:
    release = threading.Event()

    class Hanging(Robot):
        def start_node(self, node: str) -> str | None:
            self.calls.append(("start_node", node, self.clock.t))
            release.wait(30)
            return None

    rig = Rig(theory)
    rig.robot = Hanging(rig.clock)
    rig.ex = RepairExecutor(
        theory,
        "tedusar",
        rig.robot,
        rig.log.append,
        clock=rig.clock,
        settings=Settings(step_timeout_s=5.0),
        background=True,
    )
    rig.healthy()
    rig.crash("jaguar_node")
    began = time.monotonic()
    try:
        rig.run(12.0)
    finally:
        release.set()
    assert time.monotonic() - began < 5.0  # the ticks did not wait for the call
    assert any("did not return within 5 s" in e.message for e in rig.log)
    assert [a for a, _, _ in rig.robot.calls] == ["start_node", "start_node"]


def test_advisory_mode_acts_only_on_an_operators_confirmation(theory: Theory) -> None:
    rig = Rig(theory, mode=Mode.ADVISE)
    rig.healthy()
    rig.crash("jaguar_node")
    rig.run(10.0)
    assert rig.robot.calls == [] and rig.ex.state is State.ADVISED
    (advice,) = rig.entries("advise")
    assert "plan 1:" in advice.message and "start_node(jaguar_node)" in advice.message
    (row,) = rig.ex.pending_rows()
    assert row.message == "start_node(jaguar_node)" and row.value("plan") == "1"
    rig.ex.confirm("7")  # not the pending plan
    rig.run(1.0)
    assert rig.robot.calls == [] and "names no pending plan" in rig.entries("confirm")[0].message
    rig.ex.confirm("1")
    rig.run(1.0)
    assert rig.robot.actions() == [("start_node", "jaguar_node")]
    assert rig.ex.pending_rows() == ()


def test_an_advised_plan_is_withdrawn_when_the_diagnosis_changes(theory: Theory) -> None:
    rig = Rig(theory, mode=Mode.ADVISE)
    rig.healthy()
    rig.crash("jaguar_node")
    rig.run(3.0)
    assert rig.ex.state is State.ADVISED
    rig.healthy()
    rig.run(0.2)
    assert rig.ex.state is State.IDLE and "withdrawn" in rig.entries("advise")[-1].message  # type: ignore[comparison-overlap]  # mypy keeps the narrowing across the calls above
    rig.ex.confirm("1")
    rig.run(3.0)
    assert rig.robot.calls == []


def test_a_dry_run_logs_the_plan_once_and_never_acts(theory: Theory) -> None:
    rig = Rig(theory, mode=Mode.DRY_RUN)
    rig.healthy()
    rig.crash("jaguar_node")
    rig.run(20.0)
    assert rig.robot.calls == []
    (hold,) = rig.entries("hold")
    assert hold.message.startswith("dry run: would execute plan 1:")
    assert "start_node(jaguar_node)" in hold.message


def test_the_command_line_sets_every_rule_and_refuses_bad_values(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from rac.cli import build_parser, main
    from rac.commands.repairer import settings_from

    given = "repairer m.yaml --advise --confirm 3 --startup-grace 5 --budget 2"
    args = build_parser("repairer").parse_args(
        [*given.split(), "--budget-window", "60", "--backoff", "4"]
    )
    s = settings_from(args)
    assert (s.mode, s.confirm_s, s.startup_grace_s) == (Mode.ADVISE, 3.0, 5.0)
    assert (s.budget, s.budget_window_s, s.backoff_s) == (2, 60.0, 4.0)
    dry = build_parser("repairer").parse_args(["repairer", "m.yaml", "--dry-run"])
    assert settings_from(dry).mode is Mode.DRY_RUN
    assert settings_from(build_parser("repairer").parse_args(["repairer", "m"])) == Settings()
    # Checked before the model is read or ROS is asked for anything.
    assert main(["repairer", str(tmp_path / "none.yaml"), "--budget", "0", "--confirm", "-1"]) == 1
    err = capsys.readouterr().err
    assert "RAC125" in err and "--budget 0" in err and "--confirm -1" in err


def test_a_node_the_plan_stops_is_not_part_of_a_shutdown(theory: Theory) -> None:
    # With a share this low, two nodes stopping together would be a shutdown: the one the
    # plan itself stops does not count.
    rig = Rig(theory, shutdown_fraction=0.1)
    rig.healthy()
    rig.observe("ok(scan)", False)
    rig.ex.diagnosis((("hokuyo_node",),))
    assert rig.until("plan", 5.0) is not None
    rig.run(0.1)
    assert rig.robot.actions() == [("stop_node", "hokuyo_node")]
    rig.observe("running(imu_node)", False)  # a crash while hokuyo_node is stopped
    rig.run(1.0)
    assert rig.entries("robot") == []
    assert rig.robot.actions() == [("stop_node", "hokuyo_node"), ("start_node", "hokuyo_node")]


def test_a_failed_request_whose_effect_shows_anyway_completes_the_step(theory: Theory) -> None:
    # The node stopped late, on its own: the kill finds nothing to kill and fails, but
    # not_running(hokuyo_node) shows: the step is done, the plan goes on.
    class Late(Robot):
        def kill_node(self, node: str) -> str | None:
            self.calls.append(("kill_node", node, self.clock.t))
            assert self.executor is not None
            self.executor.observe(Verdict(self.clock.t, Atom("running", (node,)), False))
            raise RacError([Diagnostic("RAC124", f"cannot kill '{node}'")])

    rig = Rig(theory)
    rig.robot = Late(rig.clock)
    rig.robot.frozen = True
    rig.ex.actuator = rig.robot
    rig.robot.executor = rig.ex
    rig.healthy()
    rig.observe("ok(scan)", False)
    rig.ex.diagnosis((("hokuyo_node",),))
    rig.run(10.0)
    assert rig.robot.actions()[:3] == [
        ("stop_node", "hokuyo_node"),
        ("kill_node", "hokuyo_node"),
        ("start_node", "hokuyo_node"),
    ]
    assert rig.entries("escalate") == []


def test_an_atom_withdrawn_by_its_observer_is_out_of_the_repairers_observations(
    theory: Theory,
) -> None:
    # A node whose process cannot be proven any more is reported unknown (a STALE row):
    # its last verdict, running, must not make start_node look done already.
    from rac.runtime.status import unknown_row

    rig = Rig(theory, confirm_s=0.5, startup_grace_s=0.0)
    rig.healthy()
    rig.run(1.0)
    rig.ex.observation_rows([unknown_row(Atom("running", ("jaguar_node",)), "n_nobs", 1.0)], 1.0)
    rig.ex.diagnosis((("jaguar_node",),))
    rig.run(3.0)
    done = [e.message for e in rig.entries("start_node")]
    assert done and not any("already" in m for m in done), done
    assert ("start_node", "jaguar_node") in rig.robot.actions()
