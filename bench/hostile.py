"""What a stranger on the ROS graph can make racc do (issue 34): every attack of
tests/attacks.py against the running tedusar demo robot and its runtime, one at a time.

    .venv-ros1/bin/python bench/hostile.py                     # ROS 1
    .venv-ros2/bin/python bench/hostile.py --ros 2             # ROS 2 (PyPI's rclpy)
    .venv-ros1/bin/python bench/hostile.py --seconds 10 --only flood,huge

For each attack, printed as a table: whether a racc process died (its pid gone), the wrong
actions (repair plans and node or device actions racc logged during the attack and 3 s
after), the observer host's cpu during the attack (percent of one core, from psutil), and
the time from a real crash right after the attack (``kill -9`` of a demo node, a different
one each time) to a diagnosis naming it: racc must still see faults once an attack ends.
The robot is tedusar on one declared machine (``machine base``), so that its observer host
runs the racc agent the agent attack aims at.  A roscore on a free port (ROS 1) or a
domain of its own (ROS 2); everything started is stopped by pid.

``--lifetime`` then runs ``bench/lifetime.py`` for the same ROS version: the issue's attacks
on the nodes racc starts (a node whose getPid answers slowly, the robot stopped after a
repair, a master gap, the robot's other nodes gone), with wrong actions and processes left
over.  racc's own nodes killed and a master restart are measured by
tests/live/test_watchdog_live.py and tests/ros1/test_master_restart_live.py (``-s`` prints
the figures).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from attacks import ATTACKS, run_attack  # noqa: E402
from live_harness import (  # noqa: E402
    ROS1,
    ROS2,
    everything_observed,
    kill_node,
    live_robot,
    placed_build,
)
from soak_support import all_ok_since, logged_done, named_since, plans  # noqa: E402

VICTIMS = ("joy_node", "rviz", "hector_mapping", "laser_alignment_node", "jaguar_teleop_node")


def racc_processes(ros: int) -> dict[str, psutil.Process]:
    """racc's runtime nodes by name (the innermost process naming each)."""
    marker = "__name:=" if ros == 1 else "__node:="
    found: dict[str, psutil.Process] = {}
    for proc in psutil.process_iter(["cmdline"]):
        for arg in proc.info["cmdline"] or []:
            if arg.startswith(marker + "racc_"):
                found[arg.removeprefix(marker)] = proc
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ros", type=int, choices=(1, 2), default=1)
    parser.add_argument("--seconds", type=float, default=8.0, help="each attack (default: 8)")
    parser.add_argument("--only", default="", help="comma-separated attacks (default: all)")
    parser.add_argument(
        "--lifetime", action="store_true", help="then run bench/lifetime.py's scenarios too"
    )
    args = parser.parse_args()
    ros = ROS1 if args.ros == 1 else ROS2
    chosen = [a for a in args.only.split(",") if a] or list(ATTACKS)
    rows: list[tuple[str, str, int, float, str, str]] = []
    with (
        tempfile.TemporaryDirectory(prefix="racc_hostile_") as tmp,
        live_robot(ros, Path(tmp)) as robot,
    ):
        watch = robot.watch
        build = placed_build(robot)
        elsewhere = robot.tmp / "elsewhere"
        elsewhere.mkdir()
        (elsewhere / "model.yaml").write_text((build / "model.yaml").read_text(), "utf-8")
        demo = robot.start_demo("hostile")
        runtime = []
        try:
            robot.wait_demo(60)
            launched = time.time()
            runtime = robot.launch_runtime(demo, build=build)
            if watch.wait(everything_observed(watch, launched, robot.quick_atoms), 60) is None:
                raise SystemExit("the runtime did not come up")
            watch.wait(all_ok_since(watch, launched, robot.quick_atoms), 60)
            racc = racc_processes(ros.version)
            print(f"ROS {ros.version}: racc's nodes {sorted(racc)}; attacks of {args.seconds:g} s")
            host = next(p for n, p in racc.items() if n.startswith("racc_observer"))
            arguments = {"reload": str(elsewhere / "model.yaml"), "agent": "base"}
            for i, attack in enumerate(chosen):
                host.cpu_percent(None)
                start = time.time()
                proc = run_attack(
                    ros.version,
                    attack,
                    args.seconds,
                    robot.env,
                    robot.tmp / f"attack_{attack}.log",
                    arguments.get(attack, ""),
                )
                proc.wait(args.seconds + 60)
                cpu = host.cpu_percent(None)
                time.sleep(3.0)
                end = time.time()
                dead = [n for n, p in racc.items() if not p.is_running()]
                wrong = plans(watch, start, end)
                victim = VICTIMS[i % len(VICTIMS)]
                crash = kill_node(ros.version, victim)
                named = watch.wait(named_since(watch, crash, victim), 30)
                latency = f"{named - crash:.2f}" if named is not None else "never"
                rows.append((attack, ", ".join(dead) or "none", len(wrong), cpu, victim, latency))
                for t, action, target, _, message in wrong:
                    print(f"  {attack}: {t - start:+.1f} s {action}({target}): {message[:120]}")
                # The crash's repair is over (its last step logged) before the next attack.
                watch.wait(partial(logged_done, watch, crash, "start_node", victim), 60)
                watch.wait(all_ok_since(watch, crash + 1.0, robot.atoms), 60)
                time.sleep(2.0)
        finally:
            robot.stop_scene(demo, runtime)
    print()
    print("| attack | racc process died | wrong actions | observer host cpu |", end="")
    print(" crash after it | diagnosed after |")
    print("| --- | --- | ---: | ---: | --- | ---: |")
    for row in rows:
        print("| {} | {} | {} | {:.0f} % | {} | {} s |".format(*row))
    clean = all(r[1] == "none" and r[2] == 0 for r in rows)
    if args.lifetime:
        lifetime = [sys.executable, str(ROOT / "bench" / "lifetime.py"), "--ros", str(args.ros)]
        clean = subprocess.run(lifetime, check=False).returncode == 0 and clean
    return 0 if clean else 1


if __name__ == "__main__":
    sys.exit(main())
