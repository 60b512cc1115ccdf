"""The healthy soak of issue 22 on racc's own tedusar demo robot on ROS 1: ``racc demo``
(eleven rospy nodes and the board simulator) and the compiled runtime, then 90 s with
stress-ng at 70 % on both cores.  Nothing is wrong with the robot, so the repairer must not
act, neither at bring-up nor under load.  The episodes and the observations that turned
negative are printed (``-s``).

Skipped where ROS 1 is not importable, a failure where RACC_REQUIRE_ROS=1 (.ci/run).
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import pytest

REQUIRED = ("roscore", "roslaunch", "stress-ng")
if os.environ.get("RACC_REQUIRE_ROS") == "1":
    import rospy  # noqa: F401
else:
    pytest.importorskip("rospy", reason="ROS 1 (python3-rospy) is not importable")
for tool in REQUIRED:
    if shutil.which(tool) is None:
        if os.environ.get("RACC_REQUIRE_ROS") == "1":
            raise RuntimeError(f"{tool} is not installed (.ci/run installs it)")
        pytest.skip(f"{tool} is not installed", allow_module_level=True)

from real_graph import real_graph  # noqa: E402
from soak_support import (  # noqa: E402
    RACC,
    ROOT,
    all_ok_since,
    cpu_load,
    episodes,
    flips,
    free_port,
    plans,
    shown_plans,
)

TEDUSAR = ROOT / "models" / "tedusar.ram"
DEMO_NODES = (
    "jaguar_node",
    "hokuyo_node",
    "laser_alignment_node",
    "imu_node",
    "joy_node",
    "jaguar_teleop_node",
    "laser_alignment_control",
    "hector_mapping",
    "rviz",
)
SOAK_SECONDS = 90.0
SOAK_LOAD = 70


def test_demo_robot_soak_under_load_repairs_nothing(tmp_path: Path) -> None:
    with real_graph(tmp_path, TEDUSAR) as graph:
        board, control = free_port(), free_port()
        demo_dir = tmp_path / "demo"
        ports = ["--board-port", str(board), "--control-port", str(control)]
        graph.procs.start([*RACC, "demo", str(TEDUSAR), "-o", str(demo_dir), *ports], "demo.log")
        assert graph.wait_nodes(DEMO_NODES, 60), "the demo's nodes did not come up"
        launched = time.time()
        graph.start_runtime("runtime.log", demo_dir / "robot.launch", f"board:=127.0.0.1:{board}")
        ok = graph.watch.wait(all_ok_since(graph.watch, launched, graph.atoms), 30)
        print(f"\ntedusar (ROS 1): all ok after {ok - launched:.2f} s" if ok else "\nnever all ok")
        with cpu_load(graph.procs, SOAK_LOAD):
            start = time.time()
            time.sleep(SOAK_SECONDS)
            end = time.time()
        acted = plans(graph.watch, launched, end)
        found = episodes(graph.watch, start, end)
        print(f"tedusar soak {SOAK_SECONDS:g} s at {SOAK_LOAD} % load, bring-up included:")
        print(f"  repair: {shown_plans(acted, launched)}")
        print(f"  diagnosis episodes: {len(found)} {[(round(t - start, 1), d) for t, d in found]}")
        print(f"  observations turned negative: {flips(graph.watch, start, end)}")
        assert not acted, "the repairer acted on the healthy demo robot"
