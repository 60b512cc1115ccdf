"""Nodes the repairer starts belong to the robot, not to racc.

A node started as a plain child of the repairer shares racc's process group: roslaunch
(which signals each node's group) and Ctrl-C in racc's terminal would stop it with racc,
leaving the robot without the node racc had just repaired.  :class:`Detached` starts each
node in a session of its own, its output in a log file and its stdin on ``/dev/null``, so
that it outlives racc.  It starts it through a guardian (:mod:`rac.runtime.guardian`), a
small process of its own session that stops the node when the robot stops (its launch
ends, its master or its other nodes are gone): the robot's lifetime bounds the node's.
The repairer keeps the guardian to reap it (no zombie while racc runs) and the node's own
pid for a later stop or kill.  Both ROS transports use it; they only say what to run.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import psutil

from rac.errors import Diagnostic, RacError
from rac.runtime.lifetime import Lifetime, start_guarded


def log_directory() -> Path:
    """Where the logs of started nodes go: ``$ROS_LOG_DIR``, else ``$ROS_HOME/log``, else
    ``~/.ros/log`` (as both ROS versions put their logs)."""
    if os.environ.get("ROS_LOG_DIR"):
        return Path(os.environ["ROS_LOG_DIR"])
    home = os.environ.get("ROS_HOME") or str(Path.home() / ".ros")
    return Path(home) / "log"


# A process racc started less than this long ago is still starting, not an old copy: a
# step's second attempt (one step time-out after the first) waits for it.
STARTING_S = 30.0


@dataclass(slots=True)
class Started:
    """A node racc started: its guardian (racc's child, which racc reaps) and the node's
    own process (the guardian's child), known by pid and start time."""

    guardian: subprocess.Popen[bytes]
    pid: int
    node: psutil.Process | None  # None: it ended before racc could look at it
    at: float = 0.0  # when it was started (time.monotonic)

    def running(self) -> bool:
        try:
            return (
                self.node is not None
                and self.node.is_running()
                and self.node.status() != psutil.STATUS_ZOMBIE
            )
        except psutil.Error:
            return False


class Detached:
    def __init__(self) -> None:
        self.procs: dict[str, Started] = {}  # node -> its latest process
        # One start at a time: a start whose call outlived the executor's step time-out
        # must not race the next attempt's proof that the old process is gone.
        self.starting = threading.Lock()

    def start(
        self,
        node: str,
        args: Sequence[str],
        env: Mapping[str, str],
        cwd: str | None = None,
        log_dir: Path | None = None,
        lifetime: Lifetime | None = None,
    ) -> tuple[int, Path]:
        """Start ``args`` for ``node`` under its guardian (:mod:`rac.runtime.guardian`), in
        a session of its own: (the node's pid, its log file).  The guardian stops the node
        when the robot stops, as ``lifetime`` says."""
        folder = (log_dir or log_directory()) / "racc_started"
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", node.strip("/")) or "node"
        log = folder / f"{stem}-{time.strftime('%Y%m%d-%H%M%S')}.log"
        try:
            folder.mkdir(parents=True, exist_ok=True)
            if cwd:
                Path(cwd).mkdir(parents=True, exist_ok=True)  # as roslaunch makes ROS_HOME
        except OSError as err:
            raise RacError([Diagnostic("RAC111", f"cannot start '{node}': {err}")]) from None
        orders = (lifetime or Lifetime()).orders(node, args, env, log, cwd)
        guardian, pid = start_guarded(orders)
        try:
            proc: psutil.Process | None = psutil.Process(pid)
        except psutil.Error:  # it ended at once: its log says why; the executor will see
            proc = None
        self.procs[node] = Started(guardian, pid, proc, time.monotonic())
        return pid, log

    def still_starting(self, node: str, within_s: float = STARTING_S) -> str | None:
        """A note when the process racc started for ``node`` less than ``within_s`` ago
        still runs: it may still be starting (a Python node importing on a loaded machine
        takes seconds), so a second start waits for it instead of replacing it."""
        started = self.procs.get(node)
        if started is None or not started.running():
            return None
        age = time.monotonic() - started.at
        if age >= within_s:
            return None
        return (
            f"pid {started.pid}, which racc started {age:.1f} s ago, still runs: waiting for "
            "it to come up instead of starting another copy"
        )

    def pid(self, node: str) -> int | None:
        """The pid of the process started for ``node``, while it runs."""
        started = self.procs.get(node)
        if started is None or not started.running():
            return None
        return started.pid

    def signal(self, node: str, sig: int, only: int | None = None) -> bool:
        """Signal the session started for ``node`` (its whole process group); False when
        none of ours runs, or (``only``) when it is not that pid's any more: a delayed
        SIGTERM must not hit the node started again since."""
        pid = self.pid(node)
        if pid is None or (only is not None and pid != only):
            return False
        try:
            os.killpg(pid, sig)
        except OSError:
            return False
        return True

    def reap(self) -> None:
        """Collect the exit status of the guardians whose node ended (no zombies)."""
        for node, started in list(self.procs.items()):
            if started.guardian.poll() is not None and not started.running():
                del self.procs[node]


def started_note(pid: int, log: Path, stop: str, lifetime: Lifetime | None = None) -> str:
    """The log's word on a started node: whose it is, what stops it and how to stop it."""
    until = (lifetime or Lifetime()).describe()
    return (
        f"started detached as pid {pid} in a session of its own: it belongs to the robot "
        f"and keeps running when racc stops, until {until} (stop it with '{stop}' or "
        f"'kill {pid}'); its output goes to {log}"
    )


def kill_pids(node: str, pids: Sequence[int]) -> str:
    """SIGKILL each pid (a frozen process gets no say); RAC124 when there is none."""
    if not pids:
        raise RacError(
            [
                Diagnostic(
                    "RAC124",
                    f"cannot kill '{node}': no process of it on this machine",
                    hint="a node on another machine must be stopped there (or racc must "
                    "reach it); kill it by hand",
                )
            ]
        )
    for pid in pids:
        with contextlib.suppress(OSError):  # gone already: killed is killed
            os.kill(pid, signal.SIGKILL)
    return f"SIGKILL to pid {', '.join(str(p) for p in pids)}"
