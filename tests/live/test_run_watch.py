"""``racc run`` and ``racc watch`` on ROS 1 and on ROS 2: the compiled observers.launch run
without roslaunch (or ros2 launch) against the tedusar demo robot; a crash must show in
``racc watch``'s output as a diagnosis, a repair and no fault again; Ctrl-C stops every
node of ``racc run`` with no traceback.  On ROS 2 the Fast DDS profile is given only as
FASTDDS_DEFAULT_PROFILES_FILE: racc passes it on under the name the installed Fast DDS
reads, and no process may say it is deprecated.  Everything started here is stopped by pid.
"""

from __future__ import annotations

import re
import socket
import subprocess
from pathlib import Path

from live_harness import LiveRobot, Ros, wait_for_text
from soak_support import RACC, free_port

# The crash comes 15 s after the runtime is seen (``crash@+15``, issue 26 item 6): however
# slowly the demo's nodes and racc run come up on a loaded machine.
CRASH_AFTER_RUNTIME = 15.0


def test_racc_run_and_watch_show_a_crash_repaired_and_stop_cleanly(robot: LiveRobot) -> None:
    ros, tmp = robot.ros, robot.tmp
    env = {k: v for k, v in robot.env.items() if k != "FASTRTPS_DEFAULT_PROFILES_FILE"}
    demo_dir = tmp / "run_demo"
    # the repair engine restarts demo nodes from the demo's own package
    if ros.version == 2:
        env["AMENT_PREFIX_PATH"] = str(demo_dir / "ros2")
    else:
        env["ROS_PACKAGE_PATH"] = str(demo_dir / "ros")
    board = free_port()
    logs = {n: tmp / f"run_{n}.log" for n in ("demo", "run", "watch")}
    procs: dict[str, subprocess.Popen[bytes]] = {}

    def start(name: str, args: list[str]) -> None:
        with open(logs[name], "wb") as out:
            procs[name] = subprocess.Popen(args, env=env, stdout=out, stderr=subprocess.STDOUT)

    pids: list[int] = []
    try:
        args = [*RACC, "demo", *ros.flag, str(robot.model), "-o", str(demo_dir)]
        args += ["--fault", f"crash@+{CRASH_AFTER_RUNTIME:g}:jaguar_node"]
        args += ["--board-port", str(board)]
        args += ["--control-port", str(free_port())]
        start("demo", args)
        assert wait_for_text(logs["demo"], "board 127.0.0.1", 30) is not None
        robot.wait_demo(40)  # the demo's nodes are up (slow on a loaded machine)
        start("watch", [*RACC, "watch", *ros.flag])
        args = [*RACC, "run", *ros.flag, str(robot.build), f"board:=127.0.0.1:{board}"]
        args += ["--robot-launch", str(demo_dir / ros.robot_launch), "diagnosis_rate:=2"]
        start("run", args)
        healthy = wait_for_text(logs["watch"], "diagnosis     no fault", 30)
        assert healthy is not None, logs["watch"].read_text()
        # ROS 2's slower discovery may show a second diagnosis for a moment
        named = "1 diagnosis: {jaguar_node}" if ros.version == 1 else "{jaguar_node}"
        crashed = wait_for_text(logs["watch"], named, CRASH_AFTER_RUNTIME + 20, healthy)
        assert crashed is not None, logs["watch"].read_text()
        done = wait_for_text(logs["watch"], "start_node jaguar_node: done", 20, crashed)
        assert done is not None, logs["watch"].read_text()
        assert wait_for_text(logs["watch"], "diagnosis     no fault", 20, crashed) is not None
        seen = wait_for_text(logs["demo"], "demo: runtime seen", 1)
        assert seen is not None, logs["demo"].read_text()
        run_text = logs["run"].read_text()
        assert "diagnosis_rate:=2" in run_text and "started racc_board_client" in run_text
        pids = [int(p) for p in re.findall(r"started racc_\w+ \(pid (\d+)\)", run_text)]
        assert len(pids) == 4
    finally:
        codes = {name: stop(procs[name]) for name in ("run", "watch", "demo") if name in procs}
        robot.stop_started()
    assert codes == {"run": 0, "watch": 0, "demo": 0}
    for name, path in logs.items():
        text = path.read_text(errors="replace")
        assert "Traceback" not in text, name
        if ros.version == 2:
            assert "KeyboardInterrupt" not in text and "deprecated" not in text, name
    stopped = "stopped 4 nodes (exit codes: racc_observer 0, racc_engine 0, racc_repairer 0"
    assert stopped in logs["run"].read_text()
    assert logs["demo"].read_text().count(f"127.0.0.1:{board}") == 1  # the address once
    for pid in pids:
        assert not Path(f"/proc/{pid}").exists() or " Z " in Path(f"/proc/{pid}/stat").read_text()


def test_demo_stops_with_rac132_when_its_board_port_is_taken(
    ros: Ros, tmp_path: Path, robot: LiveRobot
) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        args = [*RACC, "demo", *ros.flag, str(robot.model), "-o", str(tmp_path / "d")]
        args += ["--board-port", str(port), "--control-port", str(free_port())]
        done = subprocess.run(args, capture_output=True, text=True, timeout=60, env=robot.env)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "RAC132" in done.stderr and "--board-port" in done.stderr
    assert "roslaunch" not in done.stdout + done.stderr  # nothing was launched


def stop(proc: subprocess.Popen[bytes], timeout: float = 30) -> int:
    """SIGINT, as Ctrl-C; its exit code (SIGKILL and a failure after ``timeout``)."""
    import signal

    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
        raise
