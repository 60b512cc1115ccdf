"""``racc run`` and ``racc watch`` on a real roscore: the compiled observers.launch run
without roslaunch against the tedusar demo robot; a crash must show in ``racc watch``'s
output as a diagnosis, a repair and no fault again; Ctrl-C stops every node of ``racc
run`` with no traceback.  Skipped like test_live.py where ROS 1 is missing; everything
started here is stopped by pid.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

if os.environ.get("RACC_REQUIRE_ROS") == "1":
    import rospy  # noqa: F401
else:
    pytest.importorskip("rospy", reason="ROS 1 (python3-rospy) is not importable")
if shutil.which("roscore") is None:
    if os.environ.get("RACC_REQUIRE_ROS") == "1":
        raise RuntimeError("roscore is not installed")
    pytest.skip("roscore is not installed", allow_module_level=True)

ROOT = Path(__file__).resolve().parents[2]
RACC = [sys.executable, "-m", "rac"]
CRASH_AT = 25.0


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


@pytest.fixture
def master(tmp_path: Path) -> Iterator[dict[str, str]]:
    port = free_port()
    env = dict(os.environ)
    env.update(
        ROS_MASTER_URI=f"http://127.0.0.1:{port}",
        ROS_IP="127.0.0.1",
        ROS_HOME=str(tmp_path / "ros_home"),
        PYTHONUNBUFFERED="1",
    )
    with open(tmp_path / "roscore.log", "wb") as log:
        core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=log, stderr=log)
    try:
        import rosgraph

        deadline = time.time() + 20
        while not rosgraph.is_master_online(env["ROS_MASTER_URI"]) and time.time() < deadline:
            time.sleep(0.2)
        yield env
    finally:
        stop(core)


def test_racc_run_and_watch_show_a_crash_repaired_and_stop_cleanly(
    master: dict[str, str], tmp_path: Path
) -> None:
    env = master
    build, demo_dir = tmp_path / "build", tmp_path / "demo"
    model = ROOT / "models" / "tedusar.ram"
    subprocess.run([*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"], check=True)
    board = free_port()
    env["ROS_PACKAGE_PATH"] = str(demo_dir / "ros")  # the repair engine restarts demo nodes
    logs = {n: tmp_path / f"{n}.log" for n in ("demo", "run", "watch")}
    procs: dict[str, subprocess.Popen[bytes]] = {}

    def start(name: str, args: list[str]) -> None:
        with open(logs[name], "wb") as out:
            procs[name] = subprocess.Popen(args, env=env, stdout=out, stderr=subprocess.STDOUT)

    try:
        args = [*RACC, "demo", str(model), "-o", str(demo_dir), "--board-port", str(board)]
        args += ["--control-port", str(free_port()), "--fault", f"crash@{CRASH_AT:g}:jaguar_node"]
        start("demo", args)
        assert wait_for(logs["demo"], "board 127.0.0.1", 30) is not None
        start("watch", [*RACC, "watch"])
        args = [*RACC, "run", str(build), "--robot-launch", str(demo_dir / "robot.launch")]
        args += [f"board:=127.0.0.1:{board}", "diagnosis_rate:=2"]
        start("run", args)
        healthy = wait_for(logs["watch"], "diagnosis     no fault", 30)
        assert healthy is not None, logs["watch"].read_text()
        crashed = wait_for(logs["watch"], "1 diagnosis: {jaguar_node}", CRASH_AT + 20, healthy)
        assert crashed is not None, logs["watch"].read_text()
        done = wait_for(logs["watch"], "start_node jaguar_node: done", 20, crashed)
        assert done is not None, logs["watch"].read_text()
        assert wait_for(logs["watch"], "diagnosis     no fault", 20, crashed) is not None
        run_text = logs["run"].read_text()
        assert "diagnosis_rate:=2" in run_text and "started racc_board_client" in run_text
        pids = [int(p) for p in re.findall(r"started racc_\w+ \(pid (\d+)\)", run_text)]
        assert len(pids) == 4
    finally:
        codes = {name: stop(procs[name]) for name in ("run", "watch", "demo") if name in procs}
    assert codes["run"] == 0 and codes["watch"] == 0
    for name, path in logs.items():
        assert "Traceback" not in path.read_text(errors="replace"), name
    assert "stopped 4 nodes (exit codes: racc_observer 0, racc_engine 0" in logs["run"].read_text()
    assert logs["demo"].read_text().count(f"127.0.0.1:{board}") == 1  # the address once
    for pid in pids:
        assert not Path(f"/proc/{pid}").exists() or "Z" in Path(f"/proc/{pid}/stat").read_text()


def test_demo_stops_with_rac132_when_its_board_port_is_taken(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        args = [*RACC, "demo", str(ROOT / "models" / "tedusar.ram"), "-o", str(tmp_path / "d")]
        args += ["--board-port", str(port), "--control-port", str(free_port())]
        done = subprocess.run(args, capture_output=True, text=True, timeout=60)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "RAC132" in done.stderr and "--board-port" in done.stderr
    assert "roslaunch" not in done.stdout + done.stderr  # nothing was launched


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
        assert wait_for(tmp_path / "demo.log", "board 127.0.0.1", 30) is not None
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
        assert stop(demo) == 0
    if restarted is not None:
        try:
            assert restarted.wait(10) is not None
        finally:
            if restarted.poll() is None:
                restarted.kill()
    assert "stopped 1 restarted node" in (tmp_path / "demo.log").read_text()
