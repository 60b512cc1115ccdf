"""Nodes the repairer starts belong to the robot, not to racc.

A node started as a plain child of the repairer shares racc's process group: roslaunch
(which signals each node's group) and Ctrl-C in racc's terminal would stop it with racc,
leaving the robot without the node racc had just repaired.  :class:`Detached` starts each
node in a session of its own (``start_new_session``), its output in a log file and its stdin
on ``/dev/null``, so that it outlives racc; the repairer only keeps the process to reap it
(no zombie while racc runs) and to know its pid for a later stop or kill.  Both ROS
transports use it; they only say what to run.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

from rac.errors import Diagnostic, RacError
from rac.runtime.procs import alive


def log_directory() -> Path:
    """Where the logs of started nodes go: ``$ROS_LOG_DIR``, else ``$ROS_HOME/log``, else
    ``~/.ros/log`` (as both ROS versions put their logs)."""
    if os.environ.get("ROS_LOG_DIR"):
        return Path(os.environ["ROS_LOG_DIR"])
    home = os.environ.get("ROS_HOME") or str(Path.home() / ".ros")
    return Path(home) / "log"


class Detached:
    def __init__(self) -> None:
        self.procs: dict[str, subprocess.Popen[bytes]] = {}  # node -> its latest process

    def start(
        self,
        node: str,
        args: Sequence[str],
        env: Mapping[str, str],
        cwd: str | None = None,
        log_dir: Path | None = None,
    ) -> tuple[int, Path]:
        """Start ``args`` for ``node`` in a session of its own: (its pid, its log file)."""
        folder = (log_dir or log_directory()) / "racc_started"
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", node.strip("/")) or "node"
        log = folder / f"{stem}-{time.strftime('%Y%m%d-%H%M%S')}.log"
        try:
            folder.mkdir(parents=True, exist_ok=True)
            if cwd:
                Path(cwd).mkdir(parents=True, exist_ok=True)  # as roslaunch makes ROS_HOME
            with open(log, "ab") as out:
                proc = subprocess.Popen(
                    list(args),
                    env=dict(env),
                    cwd=cwd,
                    stdin=subprocess.DEVNULL,
                    stdout=out,
                    stderr=subprocess.STDOUT,
                    start_new_session=True,
                    close_fds=True,
                )
        except OSError as err:
            raise RacError([Diagnostic("RAC111", f"cannot start '{node}': {err}")]) from None
        self.procs[node] = proc
        return proc.pid, log

    def pid(self, node: str) -> int | None:
        """The pid of the process started for ``node``, while it runs."""
        proc = self.procs.get(node)
        if proc is None or proc.poll() is not None or not alive(proc.pid):
            return None
        return proc.pid

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
        """Collect the exit status of started nodes that ended (no zombies)."""
        for node, proc in list(self.procs.items()):
            if proc.poll() is not None:
                del self.procs[node]


def started_note(pid: int, log: Path, stop: str) -> str:
    """The log's word on a started node: whose it is and how to stop it."""
    return (
        f"started detached as pid {pid} in a session of its own: it belongs to the robot "
        f"and keeps running when racc stops (stop it with '{stop}' or 'kill {pid}'); "
        f"its output goes to {log}"
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
