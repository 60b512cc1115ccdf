"""``racc run --ros 2`` and ``racc watch --ros 2`` with real rclpy processes: the compiled
observers.launch.xml run without ros2 launch against the tedusar demo robot; a crash must
show in ``racc watch``'s output as a diagnosis, a repair and no fault again; Ctrl-C stops
every node of ``racc run`` and of the demo with no traceback.  Skipped like test_live.py
where rclpy is missing.  The Fast DDS profile is given only as
FASTDDS_DEFAULT_PROFILES_FILE: racc passes it on under the name the installed Fast DDS
reads.  Everything started here is stopped by pid.
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

if os.environ.get("RACC_REQUIRE_ROS2") == "1":
    import rclpy  # noqa: F401
else:
    pytest.importorskip("rclpy", reason="ROS 2 (rclpy) is not importable")

ROOT = Path(__file__).resolve().parents[2]
RACC = [sys.executable, "-m", "rac"]
PROFILE = Path(__file__).with_name("fastdds_localhost.xml")
CRASH_AT = 30.0
NODES = 9  # in tedusar


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def stop(proc: subprocess.Popen[bytes], timeout: float = 30) -> int:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
        raise


def wait_for(path: Path, text: str, timeout: float, after: int = 0) -> int | None:
    """The offset in ``path`` just past ``text`` (searched from ``after``), or None."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        found = path.read_text(errors="replace").find(text, after)
        if found >= 0:
            return found + len(text)
        time.sleep(0.2)
    return None


def test_racc_run_and_watch_on_ros2_show_a_crash_repaired_and_stop_cleanly(
    tmp_path: Path,
) -> None:
    env = {k: v for k, v in os.environ.items() if "DEFAULT_PROFILES_FILE" not in k}
    env.update(
        ROS_DOMAIN_ID=str((os.getpid() + 37) % 100 + 1),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_LOG_DIR=str(tmp_path / "ros_log"),
        FASTDDS_DEFAULT_PROFILES_FILE=str(PROFILE),
        PYTHONUNBUFFERED="1",
    )
    build, demo_dir = tmp_path / "build", tmp_path / "demo"
    # tedusar without the servo's 'interval' (its message type has no Python package here:
    # docs/runtime.md, "Known limits")
    lines = (ROOT / "models" / "tedusar.ram").read_text(encoding="utf-8").splitlines()
    model = tmp_path / "tedusar.ram"
    model.write_text("\n".join(x for x in lines if not x.startswith("interval ")) + "\n")
    subprocess.run(
        [*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"], check=True, env=env
    )
    board = free_port()
    env["AMENT_PREFIX_PATH"] = str(demo_dir / "ros2")  # the repair engine restarts demo nodes
    logs = {n: tmp_path / f"{n}.log" for n in ("demo", "run", "watch")}
    procs: dict[str, subprocess.Popen[bytes]] = {}

    def start(name: str, args: list[str]) -> None:
        with open(logs[name], "wb") as out:
            procs[name] = subprocess.Popen(args, env=env, stdout=out, stderr=subprocess.STDOUT)

    try:
        args = [*RACC, "demo", "--ros", "2", str(model), "-o", str(demo_dir)]
        args += ["--fault", f"crash@{CRASH_AT:g}:jaguar_node", "--board-port", str(board)]
        args += ["--control-port", str(free_port())]
        start("demo", args)
        assert wait_for(logs["demo"], "board 127.0.0.1", 30) is not None
        # every demo node up (their start is slow on a loaded machine) before the runtime
        deadline = time.time() + 40
        while logs["demo"].read_text().count(": publishes") < NODES and time.time() < deadline:
            time.sleep(0.2)
        start("watch", [*RACC, "watch", "--ros", "2"])
        args = [*RACC, "run", "--ros", "2", str(build), f"board:=127.0.0.1:{board}"]
        args += ["--robot-launch", str(demo_dir / "robot.launch.xml")]
        start("run", args)
        healthy = wait_for(logs["watch"], "diagnosis     no fault", 30)
        assert healthy is not None, logs["watch"].read_text()
        crashed = wait_for(logs["watch"], "{jaguar_node}", CRASH_AT + 20, healthy)
        assert crashed is not None, logs["watch"].read_text()
        done = wait_for(logs["watch"], "start_node jaguar_node: done", 20, crashed)
        assert done is not None, logs["watch"].read_text()
        run_text = logs["run"].read_text()
        assert "started racc_board_client" in run_text
        pids = [int(p) for p in re.findall(r"started racc_\w+ \(pid (\d+)\)", run_text)]
        assert len(pids) == 4
    finally:
        codes = {name: stop(procs[name]) for name in ("run", "watch", "demo") if name in procs}
    assert codes == {"run": 0, "watch": 0, "demo": 0}
    for name, path in logs.items():
        text = path.read_text(errors="replace")
        assert "Traceback" not in text and "KeyboardInterrupt" not in text, name
        assert "deprecated" not in text, name
    stopped = "stopped 4 nodes (exit codes: racc_observer 0, racc_engine 0, racc_repairer 0"
    assert stopped in logs["run"].read_text()
    for pid in pids:
        assert not Path(f"/proc/{pid}").exists() or " Z " in Path(f"/proc/{pid}/stat").read_text()
