"""The healthy soak of issue 22 on racc's tedusar demo robot on ROS 2: ``racc demo --ros 2``
and the processes of the compiled observers.launch.xml (started as tests/ros2/test_live.py
starts them), then 90 s with stress-ng at 70 % on both cores.  Nothing is wrong with the
robot, so the repairer must not act, neither at bring-up nor under load.

The runtime's topics are read by a monitor process (tests/soak_support.py), in a domain of
this test (not test_live.py's), discovery on this host only.  Skipped where rclpy is not
importable, a failure where RACC_REQUIRE_ROS2=1 (.ci/run).
"""

from __future__ import annotations

import os
import random
import shutil
import subprocess
import time
from pathlib import Path

import pytest

if os.environ.get("RACC_REQUIRE_ROS2") == "1":
    import rclpy  # noqa: F401
else:
    pytest.importorskip("rclpy", reason="ROS 2 (rclpy) is not importable")
if shutil.which("stress-ng") is None:
    if os.environ.get("RACC_REQUIRE_ROS2") == "1":
        raise RuntimeError("stress-ng is not installed (.ci/run installs it)")
    pytest.skip("stress-ng is not installed", allow_module_level=True)

from soak_support import (
    RACC,
    ROOT,
    Processes,
    all_ok_since,
    cpu_load,
    episodes,
    flips,
    free_port,
    plans,
    shown_plans,
    start_watch,
)

TEDUSAR = ROOT / "models" / "tedusar.ram"
FASTDDS_PROFILE = Path(__file__).with_name("fastdds_localhost.xml")
DEMO_NODES = {"jaguar_node", "imu_node", "hokuyo_node", "hector_mapping", "joy_node"}
SOAK_SECONDS = 90.0
SOAK_LOAD = 70


def ros2_env(tmp: Path) -> dict[str, str]:
    taken = os.getpid() % 100 + 1  # test_live.py's domain in this pytest run
    domain = random.choice([d for d in range(1, 101) if d != taken])
    env = dict(os.environ)
    env.update(
        ROS_DOMAIN_ID=str(domain),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_LOG_DIR=str(tmp / "ros_log"),
        AMENT_PREFIX_PATH=str(tmp / "prefix"),
        PYTHONUNBUFFERED="1",
        FASTRTPS_DEFAULT_PROFILES_FILE=str(FASTDDS_PROFILE),
        FASTDDS_DEFAULT_PROFILES_FILE=str(FASTDDS_PROFILE),
    )
    return env


def model_without_interval(tmp: Path) -> Path:
    """tedusar without its servo 'interval': on ROS 2 the demo's tedusar_msgs/ServoState is
    a stand-in type no observer can read (docs/runtime.md, "Known limits"; test_live.py)."""
    lines = TEDUSAR.read_text(encoding="utf-8").splitlines()
    model = tmp / "tedusar.ram"
    model.write_text("\n".join(x for x in lines if not x.startswith("interval ")) + "\n")
    return model


def test_demo_robot_soak_under_load_repairs_nothing_on_ros2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rac.load.files import load_observers
    from rac.ros2.launch import command_line, load_launch

    env = ros2_env(tmp_path)
    monkeypatch.setenv("AMENT_PREFIX_PATH", env["AMENT_PREFIX_PATH"])  # load_launch reads it
    run = [*RACC, "ros-package", "--ros", "2", "-o", str(tmp_path / "prefix"), "-q"]
    subprocess.run(run, check=True, env=env)
    model, build = model_without_interval(tmp_path), tmp_path / "build"
    run = [*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"]
    subprocess.run(run, check=True, env=env)
    atoms = sum(len(s.atoms) for s in load_observers(build / "observers.yaml")[1])
    procs = Processes(env, tmp_path)
    try:
        watch = start_watch(procs, "ros2")
        board, control = free_port(), free_port()
        demo_dir = tmp_path / "demo"
        ports = ["--board-port", str(board), "--control-port", str(control)]
        procs.start(
            [*RACC, "demo", "--ros", "2", str(model), "-o", str(demo_dir), *ports], "demo.log"
        )
        up = watch.wait(lambda: time.time() if watch.nodes >= DEMO_NODES else None, 60)
        assert up is not None, f"the demo's nodes did not come up: {sorted(watch.nodes)}"
        launched = time.time()
        arguments = {"robot_launch": str(demo_dir / "robot.launch.xml")}
        arguments["board"] = f"127.0.0.1:{board}"
        for entry in load_launch(build / "observers.launch.xml", arguments):
            procs.start(command_line(entry), f"{entry.name}.log")
        ok = watch.wait(all_ok_since(watch, launched, atoms), 30)
        print(f"\ntedusar (ROS 2): all ok after {ok - launched:.2f} s" if ok else "\nnever all ok")
        with cpu_load(procs, SOAK_LOAD):
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
        procs.stop_all()
