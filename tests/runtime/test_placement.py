"""Whose process a node's is (rac.runtime.placement): a pid is watched only when proven to
be the node's; otherwise the node is watched through the middleware and its properties are
unknown, never ok.  The PID-namespace cases run a real process under ``unshare --pid``
(root, as CI is)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest
from live_procs import NetPair, can_make_netns, can_unshare

from rac.load.theory import load_theory
from rac.logic import Atom
from rac.observe import NodeSample, PropertySample, Verdict
from rac.passes.observers import ObserverSpec
from rac.runtime import placement
from rac.runtime.diagnoser import Diagnoser
from rac.runtime.host import HostLoop, HostStep, ObserverHost
from rac.runtime.placement import (
    Found,
    holds_port,
    in_own_pid_namespace,
    listening_pid,
    names_node,
    prove_by_cmdline,
    prove_ros1,
    silent_ros1,
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


needs_unshare = pytest.mark.skipif(
    not can_unshare(), reason="unshare --pid needs root (CI runs as root)"
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


def test_a_slow_answer_is_no_crash_and_a_long_silence_is_unknown_not_a_crash() -> None:
    """A middleware-watched node that does not answer in time (a busy node on a loaded
    machine) keeps its last answer for UNANSWERED_HOLD_S; one that stays silent longer is
    unknown (no sample at all, never not running) until it answers or refuses (gone)."""
    answers: list[Resolved] = [Found(None, "in a container")]
    probe = ProcessProbe(["talker"], lambda n: answers[0], resolve_every_s=0.5)

    def running(t: float) -> bool | None:
        samples = [e for e in probe.sample(t) if isinstance(e, NodeSample)]
        return samples[0].running if samples else None

    assert running(0.0)
    answers[0] = UNANSWERED
    assert all(running(t / 10) for t in range(5, 5 + int(UNANSWERED_HOLD_S * 10)))
    # Silent since 0.5 s: whether it runs is unknown, for as long as the silence lasts.
    assert [running(t / 10) for t in range(25, 120)] == [None] * 95
    assert probe.unknown("talker")
    ((node, found),) = probe.take_placements()[-1:]
    assert node == "talker" and found.unknown and found.watched == "unknown"
    answers[0] = Found(None, "in a container")
    assert running(12.0)  # answers again
    assert not probe.unknown("talker")
    answers[0] = UNANSWERED
    assert running(12.5)  # the hold starts afresh
    assert running(15.0) is None
    answers[0] = None  # refused: gone at once, unknown no more
    assert running(15.5) is False
    assert not probe.unknown("talker")
    # A node whose proven process has gone is not running, answer or none.
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    answers[0] = Found(child.pid, "mine")
    assert running(16.0)
    child.kill()
    child.wait(5)
    answers[0] = UNANSWERED
    assert running(16.5) is False


def test_the_running_atom_of_a_silent_node_is_unknown_then_restored() -> None:
    """The host withdraws running(talker) while it is unknown (a STALE "unknown" row, out
    of the engine's Θ, never not_running), and restores the observer's verdict once the
    node answers; a node that refuses then is not running."""
    answers: list[Resolved] = [Found(None, "in a container")]
    probe = ProcessProbe(["talker"], lambda n: answers[0], resolve_every_s=0)
    clock = [0.0]
    host = ObserverHost(SPECS[:1], clock=lambda: clock[0])
    loop = HostLoop(host, probe)
    atom = Atom("running", ("talker",))

    def step(t: float) -> HostStep:
        clock[0] = t
        return loop.step(t)

    def row(t: float) -> tuple[int, str]:
        rows = {r.name: r for r in step(t).rows or host.rows()}
        return rows["running(talker)"].level, rows["running(talker)"].message

    assert row(0.0) == (0, "running(talker)")
    answers[0] = UNANSWERED
    assert row(1.0) == (0, "running(talker)")  # held
    lines = step(1.0 + UNANSWERED_HOLD_S).lines
    assert any("watch talker: unknown" in line for line in lines), lines
    assert any("observation unknown running(talker)" in line for line in lines)
    for t in range(4, 30):
        assert row(float(t)) == (STALE, "unknown")
    assert atom not in host.current
    answers[0] = Found(None, "in a container")
    lines = step(30.0).lines
    assert any("observation running(talker)" in line for line in lines), lines
    assert host.current[atom].positive
    answers[0] = UNANSWERED
    for t in range(31, 40):
        step(float(t))
    assert atom not in host.current
    answers[0] = None  # refused: the node is gone
    levels = [row(40.0 + t / 10)[0] for t in range(10)]
    assert levels[-1] == 2 and STALE not in levels[1:], levels


def test_getpid_that_times_out_finds_the_process_by_its_port_and_a_refused_one_is_gone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """ROS 1's liveness ask: a node's XML-RPC server that accepts and never answers
    (XMLRPC_TIMEOUT_S) is proven by the process that holds its port, watched as usual;
    unanswered only when no local process of it is proven; a port nobody listens on is
    gone."""
    from rac.ros1 import common

    mute = socket.socket()
    mute.bind(("127.0.0.1", 0))
    mute.listen(4)  # the connection is accepted by the kernel; no answer ever comes
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))
    closed_port = closed.getsockname()[1]
    closed.close()
    try:
        port = mute.getsockname()[1]
        uri = {"mute": f"http://127.0.0.1:{port}/", "gone": f"http://127.0.0.1:{closed_port}/"}
        monkeypatch.setattr(common, "node_uri", lambda node: uri.get(node))
        began = time.monotonic()
        found = common.node_liveness("mute")
        assert isinstance(found, Found) and found.pid == os.getpid(), found
        assert f"holds its XML-RPC port {port}" in found.how
        assert time.monotonic() - began < common.XMLRPC_TIMEOUT_S + 1.0
        assert common.resolve_pid("mute") == found  # the repairer stops it by that pid
        assert common.node_liveness("gone") is None
        assert common.node_liveness("unregistered") is None
        # No process holds the port here, none names the node: unanswered (unknown).
        monkeypatch.setattr(placement, "listening_pid", lambda port: None)
        assert common.node_liveness("mute") == UNANSWERED
        assert common.resolve_pid("mute") is None
    finally:
        mute.close()


def test_a_silent_node_is_found_by_its_command_line(monkeypatch: pytest.MonkeyPatch) -> None:
    # The master did not answer (no URI, no port): the one process naming the node.
    named = subprocess.Popen(
        [sys.executable, "-c", "import time; time.sleep(30)", "__name:=silent_talker"]
    )
    try:
        deadline = time.time() + 10
        found = None
        while found is None and time.time() < deadline:
            found = silent_ros1("silent_talker", None)
        assert found is not None and found.pid == named.pid and "names it" in found.how
        assert silent_ros1("ns/silent_talker", None) is None  # another namespace's name
        assert silent_ros1("no_such_talker", None) is None
    finally:
        named.kill()
        named.wait(5)


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
