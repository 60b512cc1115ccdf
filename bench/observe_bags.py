"""The observer host on real nodes we did not write, under CPU load: ``rosbag play --loop``
of real recordings, ``racc observe`` on a real roscore, and ``stress-ng`` on every core.

Run (ROS 1 venv; Debian's rosbag and stress-ng):

    .venv-ros1/bin/python bench/observe_bags.py --seconds 60 --load 90

The bags default to the PR2's joint states (100 Hz, old roslib/Header) and the Jackal's IMU
and odometry (50 Hz) in ../shared/data; each plays with --loop under its own node name, and
the model gives each topic its nominal rate (±10 %).  After 15 s of bring-up, stress-ng
loads every core for --seconds.  Printed: the negative verdicts the observer host logged
meanwhile (every one is false: nothing is wrong), and its starvation lines.
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RACC = [sys.executable, "-m", "rac"]
DATA = ROOT.parent / "shared" / "data"  # the real recordings beside the project
MODEL = """robot bags
topic /joint_states : sensor_msgs/JointState @ 100 Hz
topic /imu/data : sensor_msgs/Imu @ 50 Hz
topic /jackal_velocity_controller/odom : nav_msgs/Odometry @ 50 Hz
node pr2_player {
  publishes /joint_states
}
node jackal_player {
  publishes /imu/data
  publishes /jackal_velocity_controller/odom
}
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wall(line: str) -> float:
    """rospy's own time stamp of a log line: ``[INFO] [1764150000.123]: ...``."""
    try:
        return float(line.split("] [", 1)[1].split("]", 1)[0])
    except (IndexError, ValueError):
        return 0.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="loaded time (default 60)")
    parser.add_argument("--load", type=int, default=90, help="stress-ng percent (default 90)")
    parser.add_argument("--pr2", default=str(DATA / "pr2_joint_states_roslib_header.bag"))
    parser.add_argument("--jackal", default=str(DATA / "jackal_imu_odom.bag"))
    args = parser.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="racc-observe-bags-"))
    port = free_port()
    env = dict(
        os.environ,
        ROS_MASTER_URI=f"http://127.0.0.1:{port}",
        ROS_IP="127.0.0.1",
        ROS_HOME=str(tmp / "ros"),
    )
    (tmp / "robot.ram").write_text(MODEL)
    procs: list[subprocess.Popen[bytes]] = []
    log = open(tmp / "log.txt", "wb")  # noqa: SIM115 - closed at exit
    observed = tmp / "observe.txt"

    def start(command: list[str], out: Path | None = None) -> None:
        sink = open(out, "wb") if out else log  # noqa: SIM115
        procs.append(
            subprocess.Popen(command, env=env, stdout=sink, stderr=sink, start_new_session=True)
        )

    try:
        start(["roscore", "-p", str(port)])
        time.sleep(3)
        build = tmp / "build"
        compile_ = [*RACC, "compile", str(tmp / "robot.ram"), "-o", str(build), "--no-svg", "-q"]
        subprocess.run(compile_, check=True, env=env)
        start(["rosbag", "play", "--loop", "-q", args.pr2, "joint_states:=/joint_states",
               "__name:=pr2_player"])  # fmt: skip
        start(["rosbag", "play", "--loop", "-q", args.jackal, "__name:=jackal_player"])
        time.sleep(2)
        start([*RACC, "observe", str(build / "observers.yaml")], observed)
        time.sleep(15)
        loaded = time.time()
        start(["stress-ng", "--cpu", "0", "--cpu-load", str(args.load), "--timeout",
               f"{int(args.seconds)}s"])  # fmt: skip
        time.sleep(args.seconds + 2)
    finally:
        for proc in reversed(procs):  # only what this script started, by process group
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGINT)
        time.sleep(3)
        for proc in procs:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
    lines = [line for line in observed.read_text(errors="replace").splitlines()]
    during = [line for line in lines if wall(line) >= loaded]
    negative = [line for line in during if "observation not_" in line]
    starved = [line for line in during if "observer host" in line]
    print(
        f"{args.seconds:g} s at stress-ng {args.load} %: {len(negative)} negative verdicts, "
        f"{len(starved)} starvation lines (log: {observed})"
    )
    for line in negative[:10] + starved[:4]:
        print("  ", line.split("]: ", 1)[-1])


if __name__ == "__main__":
    main()
