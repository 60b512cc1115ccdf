"""Processes of the live placement tests (containers, second hosts): started, watched line
by line with the time each line came, and stopped by PID (never by name)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RACC = [sys.executable, "-m", "rac"]

CHAT_MODEL = """robot chat
topic /chatter : std_msgs/String @ 10 Hz
node talker {
  publishes /chatter
  limits cpu 90 %, mem 900 MB
}
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def chat_model(tmp: Path, text: str = CHAT_MODEL) -> Path:
    path = tmp / "chat.ram"
    path.write_text(text, encoding="utf-8")
    return path


def contained_argv(argv: Sequence[str]) -> list[str]:
    """``argv`` in its own PID namespace, as a container runs it (getPid answers 1)."""
    return ["unshare", "--pid", "--fork", "--mount-proc", *argv]


def stop(proc: subprocess.Popen[bytes], sig: int = signal.SIGINT) -> None:
    """SIGINT (roslaunch and rospy end their children), then SIGKILL; a process started in
    its own session loses its whole group."""
    if proc.poll() is None:
        try:
            if os.getpgid(proc.pid) == proc.pid:
                os.killpg(proc.pid, sig)
            else:
                proc.send_signal(sig)
            proc.wait(15)
        except (subprocess.TimeoutExpired, ProcessLookupError):
            pass
    if proc.poll() is None:
        try:
            if os.getpgid(proc.pid) == proc.pid:
                os.killpg(proc.pid, signal.SIGKILL)
            else:
                proc.kill()
        except ProcessLookupError:
            pass
        proc.wait(5)


class Watcher:
    """A process whose output lines are kept with the time each arrived."""

    def __init__(self, argv: Sequence[str], env: dict[str, str], log: Path | None = None) -> None:
        self.proc = subprocess.Popen(
            list(argv),
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        self.lines: list[tuple[float, str]] = []
        self.log = log
        self._lock = threading.Lock()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:
            line = raw.decode("utf-8", "replace").rstrip("\n")
            with self._lock:
                self.lines.append((time.time(), line))
            if self.log is not None:
                with open(self.log, "a", encoding="utf-8") as f:
                    f.write(line + "\n")

    def lines_since(self, t: float) -> list[tuple[float, str]]:
        with self._lock:
            return [(s, line) for s, line in self.lines if s >= t]

    def text(self) -> str:
        with self._lock:
            return "\n".join(line for _, line in self.lines)

    def wait(self, what: Callable[[], float | None], timeout: float) -> float | None:
        deadline = time.time() + timeout
        while time.time() < deadline:
            found = what()
            if found is not None:
                return found
            time.sleep(0.05)
        return None

    def wait_line(self, needle: str, timeout: float, since: float = 0.0) -> float | None:
        def found() -> float | None:
            hits = [t for t, line in self.lines_since(since) if needle in line]
            return hits[0] if hits else None

        return self.wait(found, timeout)


def start_roscore(port: int, env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    import rosgraph

    out = open(log, "wb")  # noqa: SIM115 - closed with the process
    core = subprocess.Popen(
        ["roscore", "-p", str(port)], env=env, stdout=out, stderr=subprocess.STDOUT
    )
    uri = env["ROS_MASTER_URI"]
    deadline = time.time() + 20
    while not rosgraph.is_master_online(uri) and time.time() < deadline:
        time.sleep(0.2)
    assert rosgraph.is_master_online(uri), "roscore did not come up"
    return core
