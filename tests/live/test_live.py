"""End to end on a real ROS graph, once on ROS 1 and once on ROS 2 (tests/live_harness.py):
the tedusar demo robot (``racc demo``) and the compiled runtime; faults are injected and
must be diagnosed, repaired and verified; a recording must train a model that diagnoses.

Everything started here is stopped by pid; roslaunch gets SIGINT so that it ends its
children.  The timings printed (``-s``) are the figures of docs/runtime.md; the assertions
are the issues' bounds.
"""

from __future__ import annotations

import re
import subprocess
import time
from collections.abc import Callable
from functools import partial

import psutil
from live_harness import (
    Demo,
    LiveRobot,
    everything_observed,
    logged,
    not_matched,
    observed_since,
    pid_alive,
    started_pids,
)
from soak_support import RACC, LogRow, Watch, all_ok_since, logged_done, named_since

# Fault times, seconds after the runtime is seen (``KIND@+T``, issue 26 item 6): the demo's
# nodes take from 5 s to over 20 s to come up on a loaded machine, and the runtime's
# qualitative observers need 10 s of history once it runs.
CRASH_AT, TRIP_AT, FREQ_AT = 22.0, 42.0, 62.0
# A second crash 2 s after a first one, while jaguar_node is being restarted.
FIRST_AT, SECOND_AT = 80.0, 82.0  # 15 s after the frequency fault for its repair
# Checked on ROS 1 only, as before the tests were merged: the driver's restart after a trip
# (and its 10 s bound) and the crash during a repair.  The ROS 2 parameter has not been
# seen to pass them yet (this session's machine ran at load 15-25): lift this once it has.
ROS1_ONLY_CHECKS = frozenset({1})


def runtime_seen(timeout: float = 10.0) -> float:
    """When the runtime's observer host started, as the demo sees it: faults written
    ``KIND@+T`` count from here."""
    from rac.runtime.demo import observer_host_started

    deadline = time.time() + timeout
    while (seen := observer_host_started()) is None and time.time() < deadline:
        time.sleep(0.1)
    assert seen is not None, "no observer host of this graph runs"
    return seen


def observed_runtime(robot: LiveRobot, demo: Demo) -> tuple[float, list[subprocess.Popen[bytes]]]:
    """The demo's nodes up, then the runtime launched and every quick atom observed: when it
    was launched, and its processes."""
    robot.wait_demo(60)
    launched, watch = time.time(), robot.watch
    runtime = robot.launch_runtime(demo)
    observed = watch.wait(everything_observed(watch, launched, robot.quick_atoms), 45)
    if observed is None:
        robot.stop(*runtime)
        with watch.lock:
            most = max((len(rows) for t, rows in watch.observations if t >= launched), default=0)
        raise AssertionError(f"the runtime did not come up ({most} observations)")
    return launched, runtime


def test_demo_robot_faults_are_diagnosed_repaired_and_verified(robot: LiveRobot) -> None:
    watch = robot.watch
    extras = robot.ros.version in ROS1_ONLY_CHECKS
    faults = [f"crash@+{CRASH_AT:g}:jaguar_node", f"trip@+{TRIP_AT:g}:jaguar"]
    faults.append(f"freq@+{FREQ_AT:g}:/scan")
    if extras:
        faults += [f"crash@+{FIRST_AT:g}:jaguar_node", f"crash@+{SECOND_AT:g}:imu_node"]
    demo = robot.start_demo("demo1", faults)
    runtime: list[subprocess.Popen[bytes]] = []
    try:
        launched = robot.wait_demo(60)
        print(f"\n{robot.ros.id}: demo nodes up after {launched - demo.epoch:.2f} s")
        runtime = robot.launch_runtime(demo)
        epoch = runtime_seen()
        print(f"runtime seen {epoch - launched:.2f} s after its launch")
        healthy = watch.wait(all_ok_since(watch, launched, robot.quick_atoms), 20)
        assert healthy is not None, "never all ok after launch"
        print(f"time to all-ok after launch (all but BiQObs): {healthy - launched:.2f} s")
        assert healthy - launched <= 5.0
        crash = epoch + CRASH_AT
        related = watch.wait(all_ok_since(watch, launched, robot.atoms), crash - time.time() - 1)
        assert related is not None, "the qualitative relations were not all matched"
        print(f"time to all-ok after launch (BiQObs included): {related - launched:.2f} s")

        named = watch.wait(named_since(watch, crash, "jaguar_node"), crash - time.time() + 10)
        assert named is not None, "the crash was not diagnosed"
        print(f"time to diagnose the crash: {named - crash:.2f} s")
        assert named - crash <= 3.0
        ok_again = watch.wait(all_ok_since(watch, named, robot.atoms), 15)
        assert ok_again is not None and logged(watch, crash, "start_node", "jaguar_node")
        print(f"time to recover from the crash: {ok_again - crash:.2f} s")
        assert ok_again - crash <= 10.0

        trip = epoch + TRIP_AT
        named = watch.wait(named_since(watch, trip, "jaguar"), trip - time.time() + 10)
        assert named is not None, "the board trip was not diagnosed as jaguar"
        print(f"time to diagnose the trip: {named - trip:.2f} s")
        ok_again = watch.wait(all_ok_since(watch, named, robot.atoms), 20)
        assert ok_again is not None, "not all ok again after the trip"
        assert logged(watch, trip, "power_up", "jaguar")
        print(f"time to recover from the trip: {ok_again - trip:.2f} s")
        if extras:
            assert logged(watch, trip, "start_node", "jaguar_node")
            assert ok_again - trip <= 10.0

        freq = epoch + FREQ_AT
        named = watch.wait(named_since(watch, freq, "hokuyo_node"), freq - time.time() + 10)
        assert named is not None, "the 5x frequency fault was not diagnosed as hokuyo_node"
        print(f"time to diagnose the frequency fault: {named - freq:.2f} s")
        ok_again = watch.wait(all_ok_since(watch, named, robot.atoms), FIRST_AT - FREQ_AT - 3)
        assert ok_again is not None, "not all ok again after the frequency fault"
        print(f"time to recover from the frequency fault: {ok_again - freq:.2f} s")

        if extras:
            check_a_crash_during_a_repair(robot, epoch)
        print(f"BiQObs not_matched seen: {not_matched(watch, epoch)}")
    finally:
        robot.stop_scene(demo, runtime)


def verified_since(watch: Watch, after: float) -> Callable[[], float | None]:
    """When the repair engine first logged a plan verified ("no fault: repaired") after
    ``after``."""

    def check() -> float | None:
        return next(
            (
                t
                for t, action, _, _, msg in watch.since(after)
                if action == "verify" and "no fault: repaired" in msg
            ),
            None,
        )

    return check


def check_a_crash_during_a_repair(robot: LiveRobot, epoch: float) -> None:
    """imu_node crashes 2 s after jaguar_node, while jaguar_node is being restarted: both
    are repaired and verified, the second without a failed verification of the first."""
    watch = robot.watch
    first, second = epoch + FIRST_AT, epoch + SECOND_AT
    named = watch.wait(named_since(watch, second, "imu_node"), second - time.time() + 10)
    assert named is not None, "the second crash (imu_node) was not diagnosed"
    ok_again = watch.wait(all_ok_since(watch, named, robot.atoms), 20)
    assert ok_again is not None, "not all ok again after two crashes"
    assert logged(watch, first, "start_node", "jaguar_node")
    print(f"time to recover from a crash during a repair: {ok_again - second:.2f} s")

    # The repair log can trail the observations by a tick.
    assert watch.wait(verified_since(watch, second), 5) is not None, "the repairs were not verified"
    with watch.lock:
        verify = [
            (level, msg)
            for t, action, _, level, msg in watch.repair_log
            if t >= first and action == "verify"
        ]
    assert logged(watch, second, "start_node", "imu_node")
    # The new fault is repaired as soon as the first repair's node is back, not after
    # a failed verification (level 1) of the first repair.
    assert verify and all(level == 0 for level, _ in verify), verify


def test_record_learn_compile_relaunch_diagnoses_a_crash(robot: LiveRobot) -> None:
    watch = robot.watch
    crash_at = 15.0  # after the learned model's runtime is seen
    demo = robot.start_demo("demo2", [f"crash@+{crash_at:g}:imu_node"])
    runtime: list[subprocess.Popen[bytes]] = []
    try:
        robot.wait_demo(60)
        tmp, ros = robot.tmp, robot.ros
        bag = tmp / ("run2" if ros.version == 2 else "run2.bag")
        robot.racc("record", *ros.flag, "-o", str(bag), "--duration", "15", "-q", timeout=60)
        learned = tmp / "learned.ram"
        graph, properties = tmp / "run2.graph.yaml", tmp / "run2.properties.csv"
        robot.racc(
            "learn", str(bag), "--graph", str(graph), "--properties", str(properties),
            "-o", str(learned), "-q",
        )  # fmt: skip
        text = learned.read_text(encoding="utf-8")
        for node in ("jaguar_node", "imu_node", "hokuyo_node"):
            assert f"node {node}" in text
        assert "/imu_data" in text and "/scan" in text
        build = tmp / "learned_build"
        robot.racc("compile", str(learned), "-o", str(build), "--no-svg", "-q", timeout=60)
        launched = time.time()
        runtime = robot.launch_runtime(demo, board=False, build=build, log="learned")
        crash = runtime_seen() + crash_at
        named = watch.wait(named_since(watch, crash, "imu_node"), crash - time.time() + 10)
        assert named is not None, "the learned model did not diagnose the crash"
        assert named > launched
        print(f"\n{ros.id}: learned model: crash diagnosed after {named - crash:.2f} s")
    finally:
        robot.stop_scene(demo, runtime)


def test_a_node_over_its_cpu_limit_is_restarted_and_verified(robot: LiveRobot) -> None:
    # A restarted process gives no cpu sample while it settles (5 s, racc observe
    # --settle): the overload's verdict stands until then, and the repair must still be
    # verified within the repairer's --verify-timeout (10 s).
    watch = robot.watch
    burn_at = 15.0
    demo = robot.start_demo("cpu", [f"cpu@+{burn_at:g}:imu_node"])
    runtime: list[subprocess.Popen[bytes]] = []
    try:
        robot.wait_demo(60)
        runtime = robot.launch_runtime(demo, board=False)
        burn = runtime_seen() + burn_at
        named = watch.wait(named_since(watch, burn, "imu_node"), burn - time.time() + 15)
        assert named is not None, "the cpu overload was not diagnosed"
        done = watch.wait(verified_since(watch, named), 40)
        log = [(round(t - burn, 2), a, lv, m) for t, a, _, lv, m in watch.since(burn)]
        assert done is not None, f"the restart was not verified: {log}"
        assert logged(watch, named, "start_node", "imu_node"), log
        # The first plan's restart is verified: no "ran but the diagnosis is still" before.
        failed = [e for e in log if (e[1] == "verify" and e[2]) or e[1] == "escalate"]
        assert not failed, failed
        print(
            f"\n{robot.ros.id}: cpu overload diagnosed after {named - burn:.2f} s, "
            f"restart verified after {done - burn:.2f} s"
        )
    finally:
        robot.stop_scene(demo, runtime)


def test_a_node_the_repair_engine_started_outlives_the_runtime(robot: LiveRobot) -> None:
    # Ctrl-C on observers.launch used to take every node the repair engine had restarted
    # with it (roslaunch scriptapi children): they belong to the robot.
    watch = robot.watch
    crash_at = 15.0
    demo = robot.start_demo("demo3", [f"crash@+{crash_at:g}:imu_node"])
    runtime: list[subprocess.Popen[bytes]] = []
    pid = None
    try:
        robot.wait_demo(60)
        runtime = robot.launch_runtime(demo, board=False)
        crash = runtime_seen() + crash_at
        named = watch.wait(named_since(watch, crash, "imu_node"), crash - time.time() + 10)
        assert named is not None, "the crash was not diagnosed"
        deadline = time.time() + 20
        while time.time() < deadline and not logged(watch, named, "start_node", "imu_node"):
            time.sleep(0.2)
        assert logged(watch, named, "start_node", "imu_node"), "imu_node was not restarted"
        ok_again = watch.wait(observed_since(watch, named, "running(imu_node)"), 5)
        assert ok_again is not None
        # The node the repair engine started last (a loaded machine may need a second
        # attempt: each start_node line that started a process names its pid).
        with watch.lock:
            lines = [e for e in watch.repair_log if e[1] in ("plan", "start_node", "stop_node")]
        pids = started_pids(watch, "imu_node")
        assert pids, lines
        pid = pids[-1]
        assert pid_alive(pid), lines
        robot.stop(*runtime)  # SIGINT to the runtime, as Ctrl-C
        assert all(p.returncode is not None for p in runtime)
        time.sleep(3.0)
        assert pid_alive(pid), "the restarted node died with the runtime"
        left = time.time()
        in_graph = watch.wait(lambda: time.time() if "imu_node" in watch.nodes else None, 3)
        assert in_graph is not None and in_graph >= left, "the restarted node left the graph"
        print(f"\nimu_node (pid {pid}) still runs {time.time() - ok_again:.1f} s after repair")
    finally:
        robot.stop_scene(demo, runtime)
    assert pid is None or not pid_alive(pid)


def test_stopping_the_robot_before_the_runtime_repairs_nothing(robot: LiveRobot) -> None:
    # The robot was shut down before racc, and racc restarted the robot's nodes.
    watch = robot.watch
    demo = robot.start_demo("demo4")
    runtime: list[subprocess.Popen[bytes]] = []
    try:
        launched, runtime = observed_runtime(robot, demo)
        # The repair engine is up (its status on /diagnostics, once a second).
        up = watch.wait(lambda: next((t for t, *_ in watch.repairer if t >= launched), None), 45)
        assert up is not None, "no status of the repair engine on /diagnostics"
        time.sleep(3.0)
        stopped = time.time()
        robot.stop(demo.proc)  # the robot's nodes stop, one after the other
        time.sleep(25.0)  # longer than confirmation, step and verification together
        with watch.lock:
            after = [(a, hw, m) for t, a, hw, _, m in watch.repair_log if t >= stopped]
        acted = [x for x in after if x[0] in ("plan", "stop_node", "start_node", "power_up")]
        assert not acted, acted
        down = [m for a, _, m in after if a == "robot" and "shutting down" in m]
        assert len(down) == 1, after
        with watch.lock:
            shown = [m for t, level, m, _ in watch.repairer if t >= stopped and level == 1]
        assert any("the robot is shutting down" in m for m in shown), shown
        print(f"\nrobot stopped: {down[0]}")
    finally:
        robot.stop_scene(demo, runtime)


def test_a_frozen_node_is_killed_after_the_step_timeout_and_restarted(robot: LiveRobot) -> None:
    # A frozen (SIGSTOP) node blocked a repair for 17 s, and the second attempt came 0.1 s
    # after the first request.  Now the polite stop is given the step time-out (5 s), then
    # the node is killed (found without asking it: it answers nothing), then restarted.
    watch = robot.watch
    demo = robot.start_demo("demo5")
    runtime: list[subprocess.Popen[bytes]] = []
    frozen: psutil.Process | None = None
    name_arg = "__node:=hokuyo_node" if robot.ros.version == 2 else "__name:=hokuyo_node"
    try:
        _, runtime = observed_runtime(robot, demo)
        time.sleep(3.0)
        # The node's own process (its body names the node too, but runs from elsewhere).
        (frozen,) = [
            p
            for p in psutil.process_iter(["cmdline", "create_time"])
            if name_arg in (p.info["cmdline"] or [])
            and str(demo.directory) in " ".join(p.info["cmdline"] or [])
        ]
        frozen_at = time.time()
        frozen.suspend()  # SIGSTOP
        deadline = time.time() + 40
        while time.time() < deadline and not logged(watch, frozen_at, "start_node", "hokuyo_node"):
            time.sleep(0.2)
        with watch.lock:
            steps = [
                (round(t - frozen_at, 2), a, m[:70])
                for t, a, hw, _, m in watch.repair_log
                if t >= frozen_at and hw == "hokuyo_node"
            ]
        print(f"\nfrozen hokuyo_node: {steps}")
        if not logged(watch, frozen_at, "start_node", "hokuyo_node"):
            with watch.lock:
                since = [(round(t - frozen_at, 2), *rest) for t, *rest in watch.repair_log]
                found = [(round(t - frozen_at, 2), d) for t, d in watch.diagnosis]
                status = [(round(t - frozen_at, 2), m) for t, _, m, _ in watch.repairer]
            raise AssertionError(
                f"not restarted: repair log {since[-12:]}; diagnoses {found[-8:]};"
                f" repairer {status[-4:]}"
            )
        asked = next(t for t, a, m in steps if a == "stop_node" and "attempt 1" in m)
        killed = next(t for t, a, m in steps if a == "stop_node" and "killed" in m)
        assert 4.9 <= killed - asked <= 7.0, steps  # a full step time-out, then the kill
        assert not frozen.is_running() or frozen.status() == psutil.STATUS_ZOMBIE
    finally:
        if frozen is not None and frozen.is_running():
            frozen.resume()
        robot.stop_scene(demo, runtime)


def first_confirm_reply(watch: Watch, after: float) -> float | None:
    """When the repairer first answered a confirmation after ``after``."""
    return next((r[0] for r in watch.since(after) if r[1] == "confirm"), None)


def test_an_advised_plan_waits_for_the_operators_confirmation(robot: LiveRobot) -> None:
    # Advisory mode (issue 22, goal 4), the way many operators run racc first: a crash
    # gives a plan on /repair_log ("advise") and nothing is done until an operator confirms
    # it with 'racc confirm ID'; then it is executed, and the log names the operator.  A
    # plan whose diagnosis changes while it waits is withdrawn and the next one advised: the
    # operator confirms the one pending, as someone reading /repair_plan would.  The plan's
    # id published by anyone without the robot's secret (issue 34) confirms nothing.
    watch = robot.watch
    crash_at = 15.0
    demo = robot.start_demo("demo6", [f"crash@+{crash_at:g}:imu_node"])
    runtime: list[subprocess.Popen[bytes]] = []
    try:
        robot.wait_demo(60)
        runtime = robot.launch_runtime(demo, board=False, mode="advise")
        crash = runtime_seen() + crash_at

        def pending() -> tuple[float, str] | None:
            """The plan awaiting confirmation: the last one advised, unless withdrawn."""
            waiting: tuple[float, str] | None = None
            for t, action, _, _, message in watch.since(crash):
                found = re.search(r"'racc confirm (\d+)'", message)
                if action == "advise" and found is not None:
                    waiting = (t, found.group(1))
                elif action == "advise" and "withdrawn" in message:
                    waiting = None
            return waiting

        def pending_since() -> float | None:
            plan = pending()
            return plan[0] if plan is not None else None

        at = watch.wait(pending_since, crash - time.time() + 20)
        assert at is not None, f"no plan advised: {watch.since(crash)}"
        time.sleep(8.0)  # longer than confirmation and a step: an acting engine would have
        acted = [r for r in watch.since(crash) if r[1] in ("plan", "stop_node", "start_node")]
        assert not acted, acted
        plan = pending()
        assert plan is not None
        forged = time.time()
        robot.publish_text("/racc_repairer/confirm", plan[1])  # no seal: a stranger's
        time.sleep(3.0)
        acted = [r for r in watch.since(forged) if r[1] in ("confirm", "start_node")]
        assert not acted, f"an unsealed confirmation was taken: {acted}"
        confirmed: list[LogRow] = []
        for _ in range(3):
            if watch.wait(pending_since, 20) is None:
                break
            plan = pending()
            assert plan is not None
            sent = time.time()
            answer = subprocess.run(
                [*RACC, "confirm", *robot.ros.flag, plan[1], "--operator", "alice"],
                env=robot.env,
                timeout=60,
                capture_output=True,
                text=True,
            )
            watch.wait(partial(first_confirm_reply, watch, sent), 15)
            confirmed = [r for r in watch.since(sent) if r[1] == "confirm"]
            if confirmed and "confirmed by alice" in confirmed[0][4]:
                assert answer.returncode == 0, answer.stdout + answer.stderr
                assert "confirmed by alice" in answer.stdout, answer.stdout
                break
        assert confirmed and "confirmed by alice" in confirmed[0][4], watch.since(crash)
        deadline = time.time() + 30
        while time.time() < deadline and logged_done(watch, at, "start_node", "imu_node") is None:
            time.sleep(0.2)
        done = logged_done(watch, at, "start_node", "imu_node")
        assert done is not None, watch.since(at)
        withdrawn = [r for r in watch.since(crash) if r[1] == "advise" and "withdrawn" in r[4]]
        print(
            f"\nadvised {at - crash:.2f} s after the crash; restarted {done - at:.2f} s after"
            f" ({len(withdrawn)} plan(s) withdrawn while waiting)"
        )
    finally:
        robot.stop_scene(demo, runtime)
