"""Never two copies, and the robot's lifetime bounds every restart (issue 34): the attacks
of the issue that concern the nodes racc starts, each on a live robot, with what it came to.

    .venv-ros1/bin/python bench/lifetime.py                       # the ROS 1 scenarios
    .venv-ros2/bin/python bench/lifetime.py --ros 2               # the ROS 2 scenarios
    .venv-ros1/bin/python bench/lifetime.py --only slow-getpid --quiet 60

The robot: a talker and a listener of a package 'chat', with racc's observer host, engine
and repairer (``--launch`` the robot's launch file).  A roscore on a free port (ROS 1), the
ROS 2 domain 44 on this host (ROS 2).  Everything started is stopped by pid.

- ``slow-getpid`` (ROS 1): the talker's XML-RPC getPid answers after 1 s (racc's time-out
  is 0.5 s), the robot started by roslaunch; racc watches it ``--quiet`` s with a bring-up
  grace of 5 s.  Wrong actions: plans, starts and stops on /repair_log (the talker is
  healthy).  Left over: copies of the talker beyond the one roslaunch started.
- ``launch-stop``: the robot started by its launch (roslaunch; ROS 2 a stand-in ``ros2
  launch``), the talker killed and restarted by racc, then the launch stopped with SIGINT
  (ROS 1: then its master).  Wrong actions: starts after the stop.  Left over: processes of
  the robot's nodes 15 s after the stop.
- ``master-gap`` (ROS 1): the robot's nodes started without a launcher, the talker killed
  and restarted by racc, racc stopped, then the master stopped for 10 s and started again.
  Wrong actions: the restarted talker stopped by the gap.  Then the master stopped for
  good: the time until the talker ends (the bound is ``--robot-gone``).
- ``others-gone`` (ROS 2): the robot's nodes started without a launcher, the talker killed
  and restarted by racc, racc stopped, then the listener stopped.  The time until the
  restarted talker ends (the bound is ``--robot-gone``).

One line per scenario: wrong actions, processes left over, the times.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "tests" / "ros1"))

from live_harness import ROS1, ROS2, Ros, environment  # noqa: E402
from live_procs import (  # noqa: E402
    CHAT_PAIR_MODEL,
    LISTENER,
    MONITOR,
    RACC,
    SLOW_GETPID_TALKER,
    TALKER,
    Watcher,
    chat_launch,
    chat_package,
    pids_naming,
    ros2_launch_command,
    stop,
    topic_rows,
)

SCENARIOS = {1: ("slow-getpid", "launch-stop", "master-gap"), 2: ("launch-stop", "others-gone")}


class Robot:
    """The chat robot in a folder of its own, its processes, and racc's runtime."""

    def __init__(self, ros: Ros, tmp: Path, slow: bool, robot_gone: float | None) -> None:
        self.ros, self.tmp, self.robot_gone = ros, tmp, robot_gone
        self.bound = robot_gone or 30.0  # how long the robot may be gone: racc's default
        self.env = environment(ros, tmp)
        if ros.version == 2:
            self.env["ROS_DOMAIN_ID"] = "44"
        v = ros.version
        talker = SLOW_GETPID_TALKER if slow else TALKER[v]
        self.bin = chat_package(tmp / "pkg", v, {"talker": talker, "listener": LISTENER[v]})
        self.launch = chat_launch(tmp / ros.robot_launch, v, ["talker", "listener"])
        (tmp / "chat.ram").write_text(CHAT_PAIR_MODEL, encoding="utf-8")
        (tmp / "monitor.py").write_text(MONITOR[v], encoding="utf-8")
        self.build = tmp / "build"
        subprocess.run(
            [*RACC, "compile", str(tmp / "chat.ram"), "-o", str(self.build), "--no-svg", "-q"],
            check=True,
        )
        self.procs: list[Watcher] = []
        self.runtime: list[Watcher] = []
        self.started: list[int] = []  # pids racc started, from /repair_log
        self.core: Watcher | None = None

    def start(self, argv: list[str], log: str) -> Watcher:
        w = Watcher(argv, self.env, self.tmp / log)
        self.procs.append(w)
        return w

    def master(self) -> Watcher:
        port = self.env["ROS_MASTER_URI"].rsplit(":", 1)[1]
        core = self.start(["roscore", "-p", port], "roscore.log")
        assert core.wait_line("started core service", 60) is not None, core.text()
        self.core = core
        return core

    def name_arg(self, node: str) -> str:
        return f"__node:={node}" if self.ros.version == 2 else f"__name:={node}"

    def pids(self, node: str) -> list[int]:
        return pids_naming(self.name_arg(node), self.tmp)

    def launched(self) -> Watcher:
        """The robot started by its launch file."""
        if self.ros.version == 1:
            return self.start(["roslaunch", str(self.launch)], "robot.log")
        ros2 = str(ros2_launch_command(self.tmp))
        return self.start([ros2, "launch", str(self.launch)], "robot.log")

    def by_hand(self) -> list[Watcher]:
        """The robot's nodes started one by one, without a launcher."""
        out = []
        for node in ("talker", "listener"):
            name = (
                ["--ros-args", "-r", f"__node:={node}"]
                if self.ros.version == 2
                else [f"__name:={node}"]
            )
            out.append(self.start([str(self.bin / node), *name], f"{node}.log"))
        return out

    def racc(self, *repairer: str) -> Watcher:
        flag = self.ros.flag
        b = self.build
        self.monitor = self.start([sys.executable, str(self.tmp / "monitor.py")], "monitor.log")
        self.runtime = [
            self.monitor,
            self.start([*RACC, "observe", str(b / "observers.yaml"), *flag], "observe.log"),
            self.start([*RACC, "engine", str(b / "model.yaml"), *flag], "engine.log"),
            self.start(
                [
                    *RACC,
                    "repairer",
                    str(b / "model.yaml"),
                    "--launch",
                    str(self.launch),
                    *([] if self.robot_gone is None else ["--robot-gone", f"{self.robot_gone:g}"]),
                    *repairer,
                    *flag,
                ],
                "repairer.log",
            ),
        ]
        return self.monitor

    def stop_racc(self) -> None:
        for w in reversed(self.runtime):
            stop(w.proc)

    def rows(self, topic: str, since: float = 0.0) -> list[tuple[float, list[Any]]]:
        return topic_rows(self.monitor, topic, since)

    def running(self, node: str, since: float = 0.0) -> float | None:
        for t, rows in self.rows("/observations", since):
            if any(r[0] == f"running({node})" and r[1] == 0 for r in rows):
                return float(t)
        return None

    def actions(self, since: float = 0.0) -> list[str]:
        """Plans, and starts and stops requested (not their "done" lines), since ``since``."""
        return [
            f"{r[0]}({r[3]})"
            for _, rows in self.rows("/repair_log", since)
            for r in rows
            if r[0] == "plan" or (r[0] in ("start_node", "stop_node") and "requested" in r[2])
        ]

    def restart_talker(self) -> tuple[int, float]:
        """Kill the talker; racc restarts it: (the new pid, seconds to running again)."""
        assert self.monitor.wait(lambda: self.running("talker"), 60), "the talker never ran"
        assert self.monitor.wait(lambda: self.running("listener"), 30), "no listener"
        time.sleep(3.0)
        crash = time.time()
        for pid in self.pids("talker"):
            os.kill(pid, signal.SIGKILL)

        def started() -> float | None:
            for _, rows in self.rows("/repair_log", crash):
                for r in rows:
                    found = re.search(r"started detached as pid (\d+)", r[2])
                    if r[0] == "start_node" and found:
                        self.started.append(int(found.group(1)))
                        return time.time()
            return None

        assert self.monitor.wait(started, 40) is not None, "racc did not restart the talker"
        back = self.monitor.wait(lambda: self.running("talker", crash + 0.5), 40)
        assert back is not None, "the restarted talker was not seen running"
        return self.started[-1], back - crash

    def close(self) -> None:
        """Stop everything by pid: what the scenario started, what racc started (from
        /repair_log), and any process left of the robot's nodes in this folder."""
        for w in reversed(self.procs):
            stop(w.proc)
        left = [*self.started, *self.pids("talker"), *self.pids("listener")]
        for pid in left:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] not in (b"Z", b"X")
    except OSError:
        return False


def _until(what: Callable[[], bool], timeout: float) -> float | None:
    began = time.monotonic()
    while time.monotonic() - began < timeout:
        if what():
            return time.monotonic() - began
        time.sleep(0.1)
    return None


def slow_getpid(robot: Robot, quiet_s: float) -> str:
    robot.master()
    robot.launched()
    robot.racc("--startup-grace", "5")
    assert _until(lambda: bool(robot.pids("talker")), 60) is not None
    original = robot.pids("talker")
    time.sleep(3.0 + quiet_s)
    wrong = robot.actions()
    copies = robot.pids("talker")
    extra = [p for p in copies if p not in original]
    return (
        f"wrong actions {len(wrong)} {wrong[:3]}; copies of the talker {len(copies)} "
        f"(extra {len(extra)}); original alive {all(_alive(p) for p in original)}"
    )


def launch_stop(robot: Robot) -> str:
    if robot.ros.version == 1:
        robot.master()
    launch = robot.launched()
    robot.racc()
    pid, back = robot.restart_talker()
    asked = time.time()
    ended: list[float] = []
    watch = threading.Thread(target=lambda: ended.append(_until(lambda: not _alive(pid), 30) or -1))
    watch.start()
    stop(launch.proc)
    if robot.core is not None:
        stop(robot.core.proc)
    watch.join()
    time.sleep(max(0.0, 15.0 - (time.time() - asked)))
    left = robot.pids("talker") + robot.pids("listener")
    wrong = robot.actions(asked)
    took = "never (30 s)" if ended[0] < 0 else f"{ended[0]:.2f} s after the launch's SIGINT"
    return (
        f"restarted talker running again {back:.2f} s after the kill; after the robot's stop: "
        f"it ended {took}, wrong actions {len(wrong)} {wrong}, left over {len(left)} {left}"
    )


def master_gap(robot: Robot, gap_s: float) -> str:
    robot.master()
    robot.by_hand()
    robot.racc()
    pid, _ = robot.restart_talker()
    robot.stop_racc()  # the node outlives racc; what follows is the guardian's alone
    assert robot.core is not None
    stop(robot.core.proc)
    time.sleep(gap_s)
    kept = _alive(pid)
    robot.master()
    time.sleep(3.0)
    kept = kept and _alive(pid)
    stop(robot.core.proc)
    ended = _until(lambda: not _alive(pid), robot.bound + 20)
    took = "never" if ended is None else f"{ended:.1f} s"
    return (
        f"master down {gap_s:g} s and back: restarted talker kept {kept} (wrong actions "
        f"{0 if kept else 1}); master gone for good: it ended after {took} (bound "
        f"{robot.bound:g} s); left over {len(robot.pids('talker'))}"
    )


def others_gone(robot: Robot) -> str:
    _, listener = robot.by_hand()
    robot.racc()
    pid, _ = robot.restart_talker()
    robot.stop_racc()
    stop(listener.proc)
    ended = _until(lambda: not _alive(pid), robot.bound + 20)
    took = "never" if ended is None else f"{ended:.1f} s"
    return (
        f"listener stopped: the restarted talker ended after {took} (bound "
        f"{robot.bound:g} s); left over {len(robot.pids('talker'))}"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ros", type=int, choices=(1, 2), default=1)
    parser.add_argument("--only", nargs="*", help="scenarios to run (default: all of --ros)")
    parser.add_argument("--quiet", type=float, default=30.0, help="slow-getpid: seconds watched")
    parser.add_argument(
        "--robot-gone", type=float, help="racc repairer's --robot-gone (default: racc's, 30)"
    )
    parser.add_argument("--gap", type=float, default=10.0, help="master-gap: seconds down")
    args = parser.parse_args()
    ros = ROS2 if args.ros == 2 else ROS1
    missing = ros.missing()
    if missing is not None:
        print(f"ROS {args.ros} cannot run here: {missing}", file=sys.stderr)
        return 2
    for name in args.only or SCENARIOS[args.ros]:
        with tempfile.TemporaryDirectory(prefix=f"racc_lifetime_{name}_") as tmp:
            robot = Robot(ros, Path(tmp), name == "slow-getpid", args.robot_gone)
            began = time.time()
            try:
                if name == "slow-getpid":
                    line = slow_getpid(robot, args.quiet)
                elif name == "launch-stop":
                    line = launch_stop(robot)
                elif name == "master-gap":
                    line = master_gap(robot, args.gap)
                else:
                    line = others_gone(robot)
            except AssertionError as err:
                line = f"could not run: {err}"
            finally:
                robot.close()
            print(f"{ros.id} {name:12s} ({time.time() - began:.0f} s): {line}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
