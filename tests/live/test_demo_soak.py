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
from soak_support import all_ok_since, cpu_load, episodes, flips, plans, shown_plans

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
        with cpu_load(robot.procs, SOAK_LOAD):
            start = time.time()
            time.sleep(SOAK_SECONDS)
            end = time.time()
        acted = plans(watch, launched, end)
        found = episodes(watch, start, end)
        print(f"tedusar soak {SOAK_SECONDS:g} s at {SOAK_LOAD} % load, bring-up included:")
        print(f"  repair: {shown_plans(acted, launched)}")
        print(f"  diagnosis episodes: {len(found)} {[(round(t - start, 1), d) for t, d in found]}")
        print(f"  observations turned negative: {flips(watch, start, end)}")
        assert not acted, "the repairer acted on the healthy demo robot"
    finally:
        robot.stop(*runtime)
        robot.stop(demo.proc)
