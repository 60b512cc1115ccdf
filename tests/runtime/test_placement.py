"""Whose process a node's is (rac.runtime.placement): a pid is watched only when proven to
be the node's; otherwise the node is watched through the middleware and its properties are
unknown, never ok.  The PID-namespace cases run a real process under ``unshare --pid``
(root, as CI is)."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest
from live_procs import NetPair, can_make_netns

from rac.load.theory import load_theory
from rac.logic import Atom
from rac.observe import NodeSample, PropertySample, Verdict
from rac.passes.observers import ObserverSpec
from rac.runtime.diagnoser import Diagnoser
from rac.runtime.host import HostLoop, ObserverHost
from rac.runtime.placement import (
    Found,
    holds_port,
    in_own_pid_namespace,
    listening_pid,
    names_node,
    prove_by_cmdline,
    prove_ros1,
)
from rac.runtime.procs import UNANSWERED, UNANSWERED_HOLD_S, ProcessProbe, Resolved
from rac.runtime.status import STALE, row_unknown, row_verdict, unknown_row

SPECS = (
    ObserverSpec("NObs", "talker_nobs", (("node", "talker"),), (Atom("running", ("talker",)),)),
    ObserverSpec(
        "PObs",
        "talker_cpu_pobs",
        (("node", "talker"), ("property", "cpu"), ("max_val", 50.0)),
        (Atom("ok", ("talker", "cpu")),),
    ),
)


def _can_unshare() -> bool:
    if shutil.which("unshare") is None:
        return False
    done = subprocess.run(
        ["unshare", "--pid", "--fork", "--mount-proc", "true"], capture_output=True, check=False
    )
    return done.returncode == 0


needs_unshare = pytest.mark.skipif(
    not _can_unshare(), reason="unshare --pid needs root (CI runs as root)"
)


@pytest.fixture
def listener() -> Iterator[int]:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        yield int(s.getsockname()[1])


@pytest.fixture
def contained() -> Iterator[tuple[int, int]]:
    """A process in its own PID namespace, as in a container: (its pid here, its pid there)."""
    code = "import os, time; print(os.getpid(), flush=True); time.sleep(60)"
    outer = subprocess.Popen(
        [
            "unshare",
            "--pid",
            "--fork",
            "--mount-proc",
            sys.executable,
            "-c",
            code,
            "__name:=talker",
        ],
        stdout=subprocess.PIPE,
        start_new_session=True,
    )
    try:
        assert outer.stdout is not None
        inside = int(outer.stdout.readline())
        deadline = time.time() + 5
        children: list[psutil.Process] = []
        while not children and time.time() < deadline:
            children = psutil.Process(outer.pid).children(recursive=True)
        yield children[-1].pid, inside
    finally:
        os.killpg(outer.pid, signal.SIGKILL)
        outer.wait(5)


def test_a_process_that_holds_the_port_is_the_nodes(listener: int) -> None:
    assert holds_port(os.getpid(), listener) and in_own_pid_namespace(os.getpid())
    found = prove_ros1("talker", os.getpid(), listener)
    assert found.pid == os.getpid() and "XML-RPC port" in found.how


def test_a_listening_port_names_its_process(listener: int) -> None:
    # A frozen ROS 1 node answers no getPid: the repairer kills the pid its XML-RPC port names.
    assert listening_pid(listener) == os.getpid()
    with socket.socket() as closed:
        closed.bind(("127.0.0.1", 0))  # bound, never listening
        assert listening_pid(closed.getsockname()[1]) is None


def test_a_pid_that_neither_holds_the_port_nor_names_the_node_is_not_trusted(
    listener: int,
) -> None:
    # Process 1 of this namespace (the init process, a shell...) is what a node in a
    # container answers to getPid.
    found = prove_ros1("talker", 1, listener)
    assert found.pid is None and found.watched == "middleware"
    assert prove_ros1("talker", 2**22 + 7, listener).pid is None  # no such process


def test_the_command_line_names_the_node() -> None:
    assert names_node(["python", "talker.py", "__name:=talker"], "/talker")
    assert names_node(["talker", "--ros-args", "-r", "__node:=talker"], "ns/talker")
    assert not names_node(["/sbin/init"], "talker")


@needs_unshare
def test_a_process_in_another_pid_namespace_is_not_trusted(contained: tuple[int, int]) -> None:
    here, inside = contained
    assert inside == 1  # what getPid would answer
    assert not in_own_pid_namespace(here)
    # Its command line names the node, but its pid is not counted in our namespace.
    assert prove_by_cmdline(here).pid is None
    assert prove_ros1("talker", here, None).pid is None
    assert prove_ros1("talker", inside, None).pid is None  # our pid 1 is someone else


@pytest.mark.skipif(not can_make_netns(), reason="ip netns needs root (CI runs as root)")
def test_a_process_of_another_host_is_not_trusted() -> None:
    # Another network namespace stands for another computer (a container with its own
    # network is one too): a matching command line there is not this host's node.
    net = NetPair().open()
    try:
        proc = subprocess.Popen(
            net.argv("a", [sys.executable, "-c", "import time; time.sleep(60)", "__node:=t"])
        )
        deadline = time.time() + 5
        while not net.pids("a") and time.time() < deadline:
            time.sleep(0.05)
        time.sleep(0.2)
        assert in_own_pid_namespace(proc.pid)
        found = prove_by_cmdline(proc.pid)
        assert found.pid is None and "network namespace" in found.how
        assert prove_ros1("t", proc.pid, None).pid is None
    finally:
        net.close()
        proc.wait(5)


def test_a_node_watched_through_the_middleware_has_no_properties() -> None:
    probe = ProcessProbe(["talker"], lambda n: Found(None, "in a container"), [("talker", "cpu")])
    events = probe.sample(0.0)
    assert [type(e) for e in events] == [NodeSample]
    assert not any(isinstance(e, PropertySample) for e in probe.sample(1.0))
    assert [(n, f.watched) for n, f in probe.take_placements()] == [("talker", "middleware")]


def test_a_slow_answer_is_no_crash_but_a_long_silence_is() -> None:
    """A middleware-watched node that does not answer in time (a busy node on a loaded
    machine) keeps its last answer for UNANSWERED_HOLD_S; one that stays silent longer,
    or refuses (gone), is not running."""
    answers: list[Resolved] = [Found(None, "in a container")]
    probe = ProcessProbe(["talker"], lambda n: answers[0], resolve_every_s=0.5)

    def running(t: float) -> bool:
        (sample,) = [e for e in probe.sample(t) if isinstance(e, NodeSample)]
        return sample.running

    assert running(0.0)
    answers[0] = UNANSWERED
    assert all(running(t / 10) for t in range(5, 5 + int(UNANSWERED_HOLD_S * 10)))
    assert not running(0.5 + UNANSWERED_HOLD_S)  # silent since 0.5 s: taken for gone
    answers[0] = Found(None, "in a container")
    assert running(3.5)  # answers again
    answers[0] = UNANSWERED
    assert running(4.0)  # the hold starts afresh
    answers[0] = None  # refused: gone at once
    assert not running(4.5)
    # A node whose proven process has gone is not running, answer or none.
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    answers[0] = Found(child.pid, "mine")
    assert running(5.0)
    child.kill()
    child.wait(5)
    answers[0] = UNANSWERED
    assert not running(5.5)


def test_getpid_that_times_out_is_unanswered_and_a_refused_one_is_gone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """ROS 1's liveness ask tells a node's XML-RPC server that accepts and never answers
    (XMLRPC_TIMEOUT_S) from a port nobody listens on."""
    from rac.ros1 import common

    mute = socket.socket()
    mute.bind(("127.0.0.1", 0))
    mute.listen(4)  # the connection is accepted by the kernel; no answer ever comes
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))
    closed_port = closed.getsockname()[1]
    closed.close()
    try:
        uri = {
            "mute": f"http://127.0.0.1:{mute.getsockname()[1]}/",
            "gone": f"http://127.0.0.1:{closed_port}/",
        }
        monkeypatch.setattr(common, "node_uri", lambda node: uri.get(node))
        began = time.monotonic()
        assert common.node_liveness("mute") == UNANSWERED
        assert time.monotonic() - began < common.XMLRPC_TIMEOUT_S + 1.0
        assert common.resolve_pid("mute") is None  # the repairer's reading is unchanged
        assert common.node_liveness("gone") is None
        assert common.node_liveness("unregistered") is None
    finally:
        mute.close()


def test_a_trusted_node_has_properties() -> None:
    probe = ProcessProbe(
        ["talker"], lambda n: Found(os.getpid(), "mine"), [("talker", "cpu")], settle_s=0
    )
    events = probe.sample(0.0)
    assert [type(e) for e in events] == [NodeSample, PropertySample]
    assert [(n, f.watched) for n, f in probe.take_placements()] == [("talker", "process")]


def test_the_host_says_unknown_for_the_properties_of_a_middleware_node() -> None:
    found = [Found(os.getpid(), "mine")]
    probe = ProcessProbe(
        ["talker"], lambda n: found[0], [("talker", "cpu")], resolve_every_s=0, settle_s=0
    )
    host = ObserverHost(SPECS, clock=lambda: time.monotonic())
    loop = HostLoop(host, probe)
    for i in range(3):
        loop.step(float(i))
    assert host.current[Atom("ok", ("talker", "cpu"))].positive
    # Now the pid is no longer proven (a restart into a container): ok(talker,cpu) must
    # not stand.
    found[0] = Found(None, "in a container")
    probe._procs.clear()  # the process went
    step = loop.step(10.0)
    assert any("watch talker: middleware" in line for line in step.lines)
    assert step.rows is not None
    by_name = {r.name: r for r in step.rows}
    cpu = by_name["ok(talker,cpu)"]
    assert cpu.level == STALE and row_unknown(cpu) == Atom("ok", ("talker", "cpu"))
    assert row_verdict(cpu, 0.0) is None
    running = by_name["running(talker)"]
    assert running.value("watched") == "middleware" and running.value("how") == "in a container"


def test_the_engine_takes_an_unknown_atom_out_of_theta(tmp_path: Path) -> None:
    model = tmp_path / "model.yaml"
    model.write_text(
        "ab: AB\nnab: NAB\nneg_prefix: not_\nprops: ['ok(talker,cpu)', 'running(talker)']\n"
        "rules: ['NAB(talker) -> ok(talker,cpu)', 'NAB(talker) -> running(talker)']\n",
        encoding="utf-8",
    )
    d = Diagnoser(load_theory(str(model)), "robot", "engine")
    atom = Atom("ok", ("talker", "cpu"))
    d.observe(Verdict(0, atom, False))
    assert d.tick().result.diagnoses == (("talker",),)
    assert row_unknown(unknown_row(atom, "x", 1.0)) == atom
    assert d.forget(atom)
    assert d.tick().result.consistent
