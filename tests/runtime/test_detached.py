"""Nodes the repairer starts belong to the robot (rac.runtime.detached): a session of their
own under a guardian (rac.runtime.guardian), a log file, stdin on /dev/null; the pid racc
gets is the node's own; signals reach only the process meant."""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

import psutil
import pytest

from rac.errors import RacError
from rac.runtime.detached import Detached, kill_pids, started_note
from rac.runtime.guardian import GUARDIAN_ENV

SLEEPER = [sys.executable, "-c", "import sys, time; print('up', flush=True); time.sleep(60)"]


def _wait_gone(pid: int, timeout: float = 5.0) -> bool:
    deadline = time.time() + timeout
    while time.time() < deadline:
        try:
            os.kill(pid, 0)
        except OSError:
            return True
        time.sleep(0.05)
    return False


def test_a_started_node_runs_in_a_session_of_its_own(tmp_path: Path) -> None:
    # roslaunch stops each node by its process group, and Ctrl-C reaches the terminal's
    # group: a node in racc's group would die with racc.
    started = Detached()
    pid, log = started.start("ns/jaguar_node", SLEEPER, dict(os.environ), log_dir=tmp_path)
    try:
        assert os.getsid(pid) == pid != os.getsid(0)
        assert os.getpgid(pid) != os.getpgid(0)
        assert log.parent == tmp_path / "racc_started" and log.name.startswith("ns_jaguar_node-")
        deadline = time.time() + 10
        while "up" not in log.read_text() and time.time() < deadline:
            time.sleep(0.05)
        assert "up" in log.read_text()
        assert started.pid("ns/jaguar_node") == pid
        assert not started.signal("ns/jaguar_node", signal.SIGTERM, only=pid + 1)
        assert started.pid("ns/jaguar_node") == pid  # the wrong pid: not signalled
        # The node is the guardian's child, and knows its guardian; the guardian is racc's.
        guardian = started.procs["ns/jaguar_node"].guardian
        assert psutil.Process(pid).ppid() == guardian.pid != pid
        assert psutil.Process(pid).environ()[GUARDIAN_ENV] == str(guardian.pid)
        assert os.getsid(guardian.pid) == guardian.pid  # detached from racc too
        assert started.signal("ns/jaguar_node", signal.SIGTERM, only=pid)
        assert _wait_gone(pid)
        assert guardian.wait(5) == 0  # the guardian ends with its node
        started.reap()
        assert started.pid("ns/jaguar_node") is None and started.procs == {}
    finally:
        if started.pid("ns/jaguar_node") is not None:
            os.killpg(pid, signal.SIGKILL)
    note = started_note(pid, log, "rosnode kill /ns/jaguar_node")
    assert "keeps running when racc stops" in note and f"kill {pid}" in note


def test_kill_needs_a_local_process() -> None:
    with pytest.raises(RacError) as err:
        kill_pids("far_node", [])
    assert err.value.diagnostics[0].code == "RAC124"
