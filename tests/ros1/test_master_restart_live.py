"""After the ROS master is stopped for 10 s and started again, racc's nodes are registered
and subscribed again within seconds, and say so (issue 34, goal 4).  Before, racc's nodes
never registered with the new master: a node killed afterwards was restarted and never
heard again ("verify: plan 7 ran but the diagnosis is still {imu_node}").  ROS 1 only:
ROS 2 has no master.  Everything started here is stopped by pid.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_harness import (
    ROS1,
    LiveRobot,
    everything_observed,
    kill_node,
    live_robot,
    start_roscore,
)
from soak_support import all_ok_since, named_since, plans

if not ROS1.required() and ROS1.missing() is not None:
    pytest.skip(f"ROS 1 cannot run here: {ROS1.missing()}", allow_module_level=True)

MASTER_GONE_S = 10.0


@pytest.fixture
def robot(tmp_path: Path) -> Iterator[LiveRobot]:
    with live_robot(ROS1, tmp_path) as live:
        yield live


def registered_again(robot: LiveRobot, node: str) -> bool:
    logs = (robot.tmp / "ros_home" / "log").rglob(f"{node}*.log")
    return any("registered again with the master" in p.read_text(errors="replace") for p in logs)


def test_after_a_master_restart_racc_registers_again_and_hears_a_restarted_node(
    robot: LiveRobot,
) -> None:
    watch = robot.watch
    demo = robot.start_demo("master_restart")
    runtime = []
    try:
        robot.wait_demo(60)
        launched = time.time()
        runtime = robot.launch_runtime(demo)
        assert watch.wait(everything_observed(watch, launched, robot.quick_atoms), 45)
        assert watch.wait(all_ok_since(watch, launched, robot.quick_atoms), 30), "never all ok"

        core = robot.procs.procs[0]  # the roscore live_robot started first
        assert "roscore" in " ".join(psutil.Process(core.pid).cmdline())
        stopped = time.time()
        robot.procs.stop(core)
        robot.procs.procs.remove(core)
        time.sleep(MASTER_GONE_S)
        start_roscore(robot.procs, robot.env)
        restarted = time.time()
        racc = ("racc_observer", "racc_engine", "racc_repairer", "racc_board_client")
        deadline = restarted + 30
        while time.time() < deadline and not all(registered_again(robot, n) for n in racc):
            time.sleep(0.5)
        missing = [n for n in racc if not registered_again(robot, n)]
        assert not missing, f"not registered with the new master: {missing}"
        print(f"\nracc's nodes registered again within {time.time() - restarted:.1f} s")
        assert plans(watch, stopped, time.time()) == [], "racc acted while the master was away"

        # A node killed now is restarted by racc and heard again.
        crash = kill_node(1, "jaguar_node")
        named = watch.wait(named_since(watch, crash, "jaguar_node"), 20)
        assert named is not None, "the crash after the master's restart was not diagnosed"
        healthy = watch.wait(all_ok_since(watch, named, robot.atoms), 40)
        assert healthy is not None, "the restarted node was not heard again"
        print(
            f"crash after the master's restart: diagnosed {named - crash:.2f} s, all ok "
            f"{healthy - crash:.2f} s after"
        )
    finally:
        robot.stop_scene(demo, runtime)
