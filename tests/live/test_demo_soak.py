"""The healthy soak of issue 22 on racc's own tedusar demo robot, on ROS 1 and on ROS 2:
``racc demo`` (its nodes and the board simulator) and the compiled runtime, then 90 s with
stress-ng at 70 % on both cores.  Nothing is wrong with the robot, so the repairer must not
act, neither at bring-up nor under load.  The episodes and the observations that turned
negative are printed (``-s``).
"""

from __future__ import annotations

import os
import shutil
import time

import pytest
from live_harness import LiveRobot
from soak_support import all_ok_since, plans, shown_plans, soak_under_load, timeline

SOAK_SECONDS = 90.0
SOAK_LOAD = 70


def test_demo_robot_soak_under_load_repairs_nothing(robot: LiveRobot) -> None:
    if shutil.which("stress-ng") is None:
        if robot.ros.required() or os.environ.get("CI"):
            raise RuntimeError("stress-ng is not installed (.ci/run installs it)")
        pytest.skip("stress-ng is not installed")
    watch = robot.watch
    demo = robot.start_demo("soak")
    robot.wait_demo(60)
    launched = time.time()
    runtime = robot.launch_runtime(demo)
    try:
        ok = watch.wait(all_ok_since(watch, launched, robot.atoms), 30)
        name = f"tedusar ({robot.ros.id})"
        print(f"\n{name}: all ok after {ok - launched:.2f} s" if ok else f"\n{name}: never all ok")
        soak = soak_under_load(
            robot.procs, watch, SOAK_LOAD, SOAK_SECONDS, f"{name}, bring-up included", launched
        )
        assert not soak.acted, "the repairer acted on the healthy demo robot"
    finally:
        robot.stop(*runtime)
        robot.stop(demo.proc)


BRING_UP_SECONDS = 60.0


def test_robot_and_runtime_started_together_repair_nothing(robot: LiveRobot) -> None:
    # At bring-up on ROS 2 the repairer "repaired" joy_node and jaguar_teleop_node, which
    # had simply not started yet: the runtime is launched here with the robot, not after
    # it, and a node never seen running has the bring-up grace (--startup-grace, 30 s).
    # Later, on a loaded CI machine, all seven small nodes were "repaired" 5.7 s after the
    # launch: their processes, measured while importing rclpy, read as cpu and memory
    # overloads.  A process is now judged by its cpu and memory only once it has run
    # --settle (5 s), and a demo node starts its body before its imports.
    watch = robot.watch
    launched = time.time()
    demo = robot.start_demo("together")
    runtime = robot.launch_runtime(demo)
    try:
        ok = watch.wait(all_ok_since(watch, launched, robot.atoms), BRING_UP_SECONDS)
        time.sleep(max(0.0, launched + BRING_UP_SECONDS - time.time()))
        acted = plans(watch, launched, time.time())
        name = f"tedusar ({robot.ros.id})"
        print(
            f"\n{name}, robot and runtime started together: "
            + (f"all ok after {ok - launched:.2f} s" if ok else "never all ok")
            + f"; repair: {shown_plans(acted, launched)}"
        )
        print(timeline(watch, launched, acted[-1][0] + 1 if acted else time.time()))  # why
        assert not acted, "the repairer acted while the robot came up"
        assert ok is not None, "the robot never came up whole"
    finally:
        robot.stop(*runtime)
        robot.stop(demo.proc)
