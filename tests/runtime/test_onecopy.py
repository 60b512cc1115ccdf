"""Never two copies of a node (rac.runtime.onecopy, issue 34): before an actuator starts a
node, a live old process of it is stopped first and proven gone; one that cannot be stopped
from here (another PID namespace, another machine) or that survives its signals stops the
start with RAC156/RAC155, and nothing is started.  Real processes, stopped by pid; the
actuators are built without a ROS session (start_node needs none)."""

from __future__ import annotations

import os
import shlex
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from xmlrpc.server import SimpleXMLRPCServer

import psutil
import pytest
from live_procs import can_unshare

from rac.errors import RacError
from rac.ros1 import actuator as ros1_module
from rac.ros1.actuator import Ros1Actuator
from rac.ros2.actuator import Ros2Actuator
from rac.runtime.detached import STARTING_S, Detached
from rac.runtime.onecopy import Copy, local_copies, prove_gone

SLEEP = "import time; time.sleep(120)"
# --restart-command: a node that sleeps, named as ros2 run names it
SLEEPER = f"{shlex.quote(sys.executable)} -c {shlex.quote(SLEEP)} --ros-args -r __node:={{node}}"
QUICK = ((signal.SIGINT, 0.5), (signal.SIGTERM, 0.5), (signal.SIGKILL, 0.5))


needs_unshare = pytest.mark.skipif(
    not can_unshare(), reason="unshare --pid needs root (CI runs as root)"
)


def _name(stem: str) -> str:
    """A node name of this test run alone (other runs share the machine's process table)."""
    return f"{stem}_{os.getpid()}"


def _gone(proc: subprocess.Popen[bytes], timeout: float = 5.0) -> bool:
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        return False
    return True


class Procs:
    def __init__(self) -> None:
        self.procs: list[subprocess.Popen[bytes]] = []

    def start(self, *argv: str, **kw: object) -> subprocess.Popen[bytes]:
        proc = subprocess.Popen(list(argv), **kw)  # type: ignore[call-overload]
        self.procs.append(proc)
        return proc  # type: ignore[no-any-return]

    def close(self) -> None:
        for proc in self.procs:
            if proc.poll() is None:
                with_group = os.getpgid(proc.pid) == proc.pid
                (os.killpg if with_group else os.kill)(proc.pid, signal.SIGKILL)
            proc.wait(10)


@pytest.fixture
def procs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Procs]:
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path))  # the started nodes' logs
    p = Procs()
    try:
        yield p
    finally:
        p.close()


def ros2_actuator(node_command: str) -> Ros2Actuator:
    """A ROS 2 actuator that starts every node with ``--restart-command``."""
    a = object.__new__(Ros2Actuator)
    a.launch_file, a.restart, a.entries = None, node_command, {}
    a.detached, a.robot, a.robot_gone_s = Detached(), (), 30.0
    return a


def _wait_named(node: str, ros: int, timeout: float = 10.0) -> list[Copy]:
    deadline = time.time() + timeout
    while time.time() < deadline:
        copies, _ = local_copies(node, ros, None)
        if copies:
            return copies
        time.sleep(0.05)
    return []


def test_an_alive_old_process_is_stopped_first_then_the_node_starts(procs: Procs) -> None:
    node = _name("talker")
    old = procs.start(sys.executable, "-c", SLEEP, "--ros-args", "-r", f"__node:={node}")
    assert [c.pid for c in _wait_named(node, 2)] == [old.pid]
    a = ros2_actuator(SLEEPER)
    try:
        note = a.start_node(node)
        assert _gone(old, 0), "the old process must be gone before the new one starts"
        new = a.detached.pid(node)
        assert new is not None and new != old.pid
        assert f"the old process pid {old.pid}" in note and "stopped it first (SIGINT)" in note
        assert "never two copies" in note and f"as pid {new}" in note
        # One copy only: the one racc started.
        assert [c.pid for c in _wait_named(node, 2)] == [new]  # once it has exec'd
        # Asked again at once (a step's second attempt, a node slow to come up under load):
        # the copy racc just started is waited for, neither stopped nor doubled.
        waiting = a.start_node(node)
        assert f"pid {new}, which racc started" in waiting and "waiting for it" in waiting
        assert a.detached.pid(node) == new and psutil.pid_exists(new)
        # Started again later: the copy racc started is stopped first, as a whole session.
        a.detached.procs[node].at -= STARTING_S
        again = a.start_node(node)
        assert f"the old process pid {new} (racc started it) of {node}" in again
        assert not psutil.pid_exists(new) or psutil.Process(new).status() == "zombie"
        assert a.detached.pid(node) not in (None, new)
    finally:
        a.detached.signal(node, signal.SIGKILL)


def test_a_process_that_ignores_sigint_and_sigterm_is_killed_first(procs: Procs) -> None:
    node = _name("stubborn")
    code = (
        "import signal, time\n"
        "for s in (signal.SIGINT, signal.SIGTERM): signal.signal(s, signal.SIG_IGN)\n"
        "print('ready', flush=True)\n"
        "time.sleep(120)\n"
    )
    old = procs.start(sys.executable, "-c", code, f"__name:={node}", stdout=subprocess.PIPE)
    assert old.stdout is not None and old.stdout.readline() == b"ready\n"
    copies, unseen = local_copies(node, 1, None)
    assert [c.pid for c in copies] == [old.pid] and unseen == []
    note = prove_gone(node, copies, unseen, QUICK)
    assert note is not None and "(SIGKILL)" in note and _gone(old, 1)


def test_nothing_alive_is_nothing_to_stop() -> None:
    assert prove_gone("nobody", [], []) is None
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait(10)
    assert prove_gone("nobody", [Copy(dead.pid, "its command line names it")], []) is None


def test_a_copy_racc_cannot_reach_stops_the_start_and_nothing_is_stopped(procs: Procs) -> None:
    node = _name("talker")
    local = procs.start(sys.executable, "-c", SLEEP, f"__name:={node}")
    copies = [Copy(local.pid, "its command line names it")]
    with pytest.raises(RacError) as err:
        prove_gone(node, copies, ["the master has it at http://arm:4100/, another machine"])
    (d,) = err.value.diagnostics
    assert d.code == "RAC156" and "never two copies" in d.message and "arm" in d.message
    assert d.hint is not None and "racc observe --machine" in d.hint
    assert local.poll() is None  # nothing was stopped: nothing will be started


def test_a_copy_that_survives_its_signals_is_rac155(
    procs: Procs, monkeypatch: pytest.MonkeyPatch
) -> None:
    node = _name("talker")
    old = procs.start(sys.executable, "-c", SLEEP, "--ros-args", "-r", f"__node:={node}")
    assert _wait_named(node, 2)

    def denied(self: psutil.Process, sig: int) -> None:
        raise psutil.AccessDenied(self.pid)

    monkeypatch.setattr(psutil.Process, "send_signal", denied)
    a = ros2_actuator(SLEEPER)
    with pytest.raises(RacError) as err:
        a.start_node(node)
    (d,) = err.value.diagnostics
    assert d.code == "RAC155" and f"pid {old.pid}" in d.message and "did not stop" in d.message
    assert a.detached.procs == {} and old.poll() is None  # nothing started


@needs_unshare
def test_a_copy_in_another_pid_namespace_stops_the_start(procs: Procs) -> None:
    node = _name("talker")
    contained = procs.start(
        "unshare",
        "--pid",
        "--fork",
        "--mount-proc",
        sys.executable,
        "-c",
        SLEEP,
        "--ros-args",
        "-r",
        f"__node:={node}",
        start_new_session=True,
    )
    deadline = time.time() + 10
    unseen: list[str] = []
    while not unseen and time.time() < deadline:
        _, unseen = local_copies(node, 2, None)
    assert unseen and "another PID namespace" in unseen[0]
    a = ros2_actuator(SLEEPER)
    with pytest.raises(RacError) as err:
        a.start_node(node)
    assert err.value.diagnostics[0].code == "RAC156"
    assert a.detached.procs == {} and contained.poll() is None


# -- ROS 1: the master's URI and the XML-RPC port -------------------------------------------


def ros1_actuator() -> Ros1Actuator:
    a = object.__new__(Ros1Actuator)
    a.detached = Detached()
    return a


LISTEN = (
    "import socket, sys, time\n"
    "s = socket.socket(); s.bind(('127.0.0.1', 0)); s.listen(4)\n"
    "print(s.getsockname()[1], flush=True)\n"
    "time.sleep(120)\n"
)


def test_ros1_the_process_holding_the_nodes_port_is_an_old_copy(
    procs: Procs, monkeypatch: pytest.MonkeyPatch
) -> None:
    node = _name("talker")
    # A server that names no node (rosrun without __name:=): the master's URI says whose.
    server = procs.start(sys.executable, "-c", LISTEN, stdout=subprocess.PIPE)
    assert server.stdout is not None
    port = int(server.stdout.readline())
    uri = f"http://127.0.0.1:{port}/"
    monkeypatch.setattr(ros1_module, "node_uri", lambda n: uri)
    a = ros1_actuator()
    copies, unseen = a.old_copies(node)
    assert [(c.pid, "XML-RPC port" in c.how) for c in copies] == [(server.pid, True)]
    assert unseen == []
    # The port taken since by another node (the master's URI is stale): not ours.
    other = procs.start(
        sys.executable, "-c", LISTEN, "__name:=somebody_else", stdout=subprocess.PIPE
    )
    assert other.stdout is not None
    uri = f"http://127.0.0.1:{int(other.stdout.readline())}/"
    assert a.old_copies(node) == ([], [])


def test_ros1_a_node_the_master_has_on_another_machine_that_answers_stops_the_start(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    server = SimpleXMLRPCServer(("127.0.0.1", 0), logRequests=False)
    server.register_function(lambda caller: [1, "", 4242], "getPid")
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        uri = f"http://127.0.0.1:{server.server_address[1]}/"
        monkeypatch.setattr(ros1_module, "node_uri", lambda n: uri)
        monkeypatch.setattr(ros1_module, "is_local_host", lambda host: False)
        copies, unseen = ros1_actuator().old_copies(_name("talker"))
        assert copies == [] and len(unseen) == 1 and "another machine" in unseen[0]
    finally:
        server.shutdown()
        server.server_close()
    # Its server gone (refused): no copy there.
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        closed = s.getsockname()[1]
    monkeypatch.setattr(ros1_module, "node_uri", lambda n: f"http://127.0.0.1:{closed}/")
    assert ros1_actuator().old_copies(_name("talker")) == ([], [])


def test_ros1_names_are_matched_in_their_namespace(procs: Procs) -> None:
    node = _name("cam")
    env = {**os.environ, "ROS_NAMESPACE": "/left"}
    left = procs.start(sys.executable, "-c", SLEEP, f"__name:={node}", env=env)
    assert [c.pid for c in _wait_named(f"left/{node}", 1)] == [left.pid]
    assert local_copies(f"right/{node}", 1, None) == ([], [])
    assert local_copies(node, 1, None) == ([], [])


def test_a_node_of_another_ros_graph_is_not_a_copy(procs: Procs) -> None:
    """Two robots (or a robot and a simulation) on one machine: another master's talker, or
    another domain's, is not this robot's old process."""
    node = _name("talker")
    ours = {**os.environ, "ROS_MASTER_URI": "http://localhost:11311", "ROS_DOMAIN_ID": "44"}
    other = {**os.environ, "ROS_MASTER_URI": "http://127.0.0.1:22422", "ROS_DOMAIN_ID": "45"}
    procs.start(sys.executable, "-c", SLEEP, f"__name:={node}", env=other)
    procs.start(sys.executable, "-c", SLEEP, "--ros-args", "-r", f"__node:={node}", env=other)
    time.sleep(0.5)
    assert local_copies(node, 1, None, ours) == ([], [])
    assert local_copies(node, 2, None, ours) == ([], [])
    # The same master under another of this machine's names is the same graph.
    same = procs.start(
        sys.executable,
        "-c",
        SLEEP,
        f"__name:={node}",
        env={**ours, "ROS_MASTER_URI": "http://127.0.0.1:11311/"},
    )
    assert [c.pid for c in _wait_named_in(node, ours)] == [same.pid]


def _wait_named_in(node: str, env: dict[str, str], timeout: float = 10.0) -> list[Copy]:
    deadline = time.time() + timeout
    while time.time() < deadline:
        copies, _ = local_copies(node, 1, None, env)
        if copies:
            return copies
        time.sleep(0.05)
    return []
