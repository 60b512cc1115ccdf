"""racc watches itself (issue 34, goal 4), on ROS 1 and ROS 2, under ``racc run``:

- the engine killed: the repairer and the observer host say "diagnosis blind" (level 2 on
  /diagnostics) within a few seconds and nothing is acted on meanwhile, not even a node
  that crashes then; ``racc run`` starts the engine again and the crash is repaired;
- the observer host killed: ``racc run`` starts it again and the observations come back.

Everything started here is stopped by pid.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import time

import psutil
from live_harness import LiveRobot, kill_node, wait_for_text
from soak_support import RACC, all_ok_since, free_port, named_since, plans

BLIND_HOLD_S = 8.0  # how long a crash must stay unrepaired while blind
BLIND_WITHIN_S = 5.0  # the engine's heartbeat is missed after 3 s; its status comes once a second


def racc_pid(log: str, node: str) -> int:
    found = re.findall(rf"(?:started|restarted) {node} \(pid (\d+)\)", log)
    assert found, f"no pid of {node} in racc run's output"
    return int(found[-1])


def blind_since(robot: LiveRobot, after: float) -> float | None:
    """When both the repairer and the observer host first said they are blind."""
    watch = robot.watch
    with watch.lock:
        repairer = [
            t for t, lv, msg, _ in watch.repairer if t >= after and lv == 2 and "blind" in msg
        ]
        host = [
            t
            for t, name, lv, msg in watch.statuses
            if t >= after and name.startswith("racc_observer") and lv == 2 and "blind" in msg
        ]
    return max(repairer[0], host[0]) if repairer and host else None


def test_racc_run_restarts_its_nodes_and_acts_on_nothing_while_blind(robot: LiveRobot) -> None:
    ros, tmp, watch = robot.ros, robot.tmp, robot.watch
    env = dict(robot.env)
    demo_dir = tmp / "watchdog_demo"
    if ros.version == 2:
        env["AMENT_PREFIX_PATH"] = str(demo_dir / "ros2")
    else:
        env["ROS_PACKAGE_PATH"] = str(demo_dir / "ros")
    board = free_port()
    logs = {n: tmp / f"watchdog_{n}.log" for n in ("demo", "run")}
    procs: dict[str, subprocess.Popen[bytes]] = {}

    def start(name: str, args: list[str]) -> None:
        with open(logs[name], "wb") as out:
            procs[name] = subprocess.Popen(
                args, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True
            )

    try:
        args = [*RACC, "demo", *ros.flag, str(robot.model), "-o", str(demo_dir)]
        args += ["--board-port", str(board), "--control-port", str(free_port())]
        start("demo", args)
        assert wait_for_text(logs["demo"], "board 127.0.0.1", 30) is not None
        robot.wait_demo(40)
        launched = time.time()
        args = [*RACC, "run", *ros.flag, str(robot.build), f"board:=127.0.0.1:{board}"]
        args += ["--robot-launch", str(demo_dir / ros.robot_launch)]
        start("run", args)
        healthy = watch.wait(all_ok_since(watch, launched, robot.quick_atoms), 60)
        assert healthy is not None, "never all ok after launch"

        # The engine hangs (SIGSTOP): racc says it is blind, and a crash meanwhile is not
        # acted on, however long it stands; once the engine answers again it is repaired.
        engine = psutil.Process(racc_pid(logs["run"].read_text(), "racc_engine"))
        lost = time.time()
        engine.suspend()
        try:
            blind = watch.wait(lambda: blind_since(robot, lost), 20)
            assert blind is not None, "the lost engine was not reported as blindness"
            print(f"\n{ros.id}: blind {blind - lost:.2f} s after the engine hung")
            # (the monitor itself may see the status a few seconds late on a loaded machine)
            assert blind - lost <= BLIND_WITHIN_S + 5.0
            crash = kill_node(robot.ros.version, "joy_node")
            time.sleep(BLIND_HOLD_S)  # far longer than the confirmation and a step
            assert plans(watch, lost, time.time()) == [], "racc acted while blind"
        finally:
            engine.resume()
        named = watch.wait(named_since(watch, time.time(), "joy_node"), 30)
        assert named is not None, "the crash was not diagnosed once the engine answered"
        repaired = watch.wait(all_ok_since(watch, named, robot.atoms), 40)
        assert repaired is not None, "the crash was not repaired once the engine answered"
        print(
            f"  the crash ({named - crash:.1f} s before it was diagnosed) repaired "
            f"{repaired - named:.2f} s after the engine answered again"
        )

        # The engine dies (SIGKILL): racc run starts it again.
        killed = time.time()
        psutil.Process(racc_pid(logs["run"].read_text(), "racc_engine")).kill()
        back = wait_for_text(logs["run"], "restarted racc_engine", 30)
        assert back is not None, logs["run"].read_text()
        assert "racc_engine ended by itself (killed by SIGKILL)" in logs["run"].read_text()
        heard = watch.wait(all_ok_since(watch, killed + 1.0, robot.atoms), 60)
        assert heard is not None, "no diagnosis again after the engine was restarted"
        print(f"  engine killed: diagnosing again {heard - killed:.2f} s after")

        # The observer host dies: racc run starts it again and the observations come back.
        host = racc_pid(logs["run"].read_text(), "racc_observer")
        killed = time.time()
        psutil.Process(host).kill()
        again = wait_for_text(logs["run"], "restarted racc_observer", 30)
        assert again is not None, logs["run"].read_text()
        observed = watch.wait(all_ok_since(watch, killed + 1.0, robot.quick_atoms), 60)
        assert observed is not None, "the observations did not come back"
        print(f"  observer host killed: all observed and ok again {observed - killed:.2f} s after")
        assert plans(watch, killed, observed) == [], "racc acted while its host came back"
    finally:
        for name in ("run", "demo"):
            if name in procs:
                stop(procs[name])
        robot.stop_started()
    text = logs["run"].read_text()
    assert "Traceback" not in text


def stop(proc: subprocess.Popen[bytes]) -> None:
    """SIGINT (racc run and the demo stop their nodes), then SIGKILL of the session."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(40)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)
