"""``racc demo`` on ROS 1 stops the nodes a repair engine restarted from its robot.launch
when it ends (docs/runtime.md, "Stopping").  ROS 1 only: it starts the restart as roslaunch
would, from the package's script.  ``racc run``/``racc watch`` on both versions are in
tests/live/test_run_watch.py.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_harness import (
    ROS1,
    check_runnable,
    environment,
    start_roscore,
    wait_for_text,
)
from soak_support import RACC, Processes, free_port

if not ROS1.required() and ROS1.missing() is not None:
    pytest.skip(f"ROS 1 cannot run here: {ROS1.missing()}", allow_module_level=True)

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def master(tmp_path: Path) -> Iterator[dict[str, str]]:
    check_runnable(ROS1)
    env = environment(ROS1, tmp_path)
    procs = Processes(env, tmp_path)
    try:
        start_roscore(procs, env)
        yield env
    finally:
        procs.stop_all()


def test_demo_stops_the_nodes_a_repair_engine_restarted(
    master: dict[str, str], tmp_path: Path
) -> None:
    """The runtime's repair engine restarts demo nodes from robot.launch; when the demo
    ends, those go too (docs/runtime.md, "Stopping")."""
    env = master
    demo_dir = tmp_path / "demo"
    args = [*RACC, "demo", str(ROOT / "models" / "tedusar.ram"), "-o", str(demo_dir)]
    args += ["--board-port", str(free_port()), "--control-port", str(free_port())]
    with open(tmp_path / "demo.log", "wb") as out:
        demo = subprocess.Popen(args, env=env, stdout=out, stderr=subprocess.STDOUT)
    restarted = None
    try:
        assert wait_for_text(tmp_path / "demo.log", "board 127.0.0.1", 30) is not None
        launch = (demo_dir / "robot.launch").read_text()
        entry = launch.split('name="jaguar_node" args="')[1].split('"')[0]
        script = demo_dir / "ros" / "racc" / "scripts" / "demo_node"
        # the repair engine's restart: the same entry, another name (the demo's own runs)
        restarted = subprocess.Popen(
            [str(script), *entry.split(), "__name:=jaguar_node_again"],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        time.sleep(3)
        assert restarted.poll() is None
    finally:
        demo.send_signal(signal.SIGINT)
        try:
            code = demo.wait(30)
        except subprocess.TimeoutExpired:
            demo.kill()
            raise
        assert code == 0
    if restarted is not None:
        try:
            assert restarted.wait(10) is not None
        finally:
            if restarted.poll() is None:
                restarted.kill()
    assert "stopped 1 restarted node" in (tmp_path / "demo.log").read_text()
