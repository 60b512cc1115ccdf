"""Never two copies of a node (issue 34): before racc starts a node, its old process is
proven gone.

Two processes of one node do harm: on ROS 1 the master, seeing a second node register
under a name, shuts the first one down ("new node registered with same name"), so a copy
started beside a slow but healthy node kills the healthy one; two drivers of one device
fight over it.  So before ``start_node`` the actuator lists every live process that may be
the node (:class:`Copy`): the process racc itself started for it earlier, a local process
whose command line names it (``__name:=`` on ROS 1, ``__node:=`` on ROS 2), and on ROS 1 the
local process holding the XML-RPC port the master has for it.  :func:`prove_gone` stops each
(SIGINT, then SIGTERM, then SIGKILL, :data:`STOP_STEPS`), checks that it is gone and says so
in the start's log line.  A copy that cannot be stopped from here (a process of another PID
namespace, a container; a node the master has on another machine whose server still
answers) is RAC156, one that survives its signals RAC155: then nothing is started, and the
executor fails the attempt and escalates as for any step that cannot be made.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import psutil

from rac.errors import Diagnostic, RacError
from rac.runtime.placement import (
    in_graph,
    in_own_pid_namespace,
    on_this_host,
    ros1_named,
    ros_graph,
)
from rac.runtime.procs import node_processes, outermost

# (signal, seconds to wait after it): short enough that the whole stop stays within the
# executor's default step time-out (5 s) with time left to start the node.
STOP_STEPS = ((signal.SIGINT, 1.5), (signal.SIGTERM, 1.0), (signal.SIGKILL, 0.5))


@dataclass(frozen=True, slots=True)
class Copy:
    """A live process that may be the node: its pid, and why it is taken for the node."""

    pid: int
    how: str  # "racc started it", "its command line names it", ...
    session: bool = False  # a session racc started: signal its whole process group


def names_another_node(cmdline: Sequence[str], node: str) -> bool:
    """The command line names a node, and not this one (a port the master still has for a
    crashed node can be taken by another node since)."""
    base = node.strip("/").rpartition("/")[2]
    named = [a.partition(":=")[2] for a in cmdline if a.startswith(("__name:=", "__node:="))]
    return bool(named) and base not in named


def local_copies(
    node: str, ros: int, started: int | None, env: Mapping[str, str] | None = None
) -> tuple[list[Copy], list[str]]:
    """The live processes of ``node`` on this machine that can be stopped from here (the
    pid racc ``started``, processes whose command line names the node), and why each other
    one cannot (a process of another PID or network namespace).  A process of another ROS
    graph than the node's environment ``env`` says (another master or domain) is another
    robot's: not a copy."""
    copies: list[Copy] = []
    unseen: list[str] = []
    if started is not None:
        copies.append(Copy(started, "racc started it", session=True))
    graph = ros_graph(os.environ if env is None else env, ros)
    if ros == 2:
        named = [p for p in node_processes(node) if in_graph(p, 2, graph, p.info["cmdline"])]
    else:
        named = ros1_named(node, unreadable=True, graph=graph)
    for proc in named:
        pid = proc.pid
        if pid == os.getpid() or any(c.pid == pid for c in copies):
            continue
        if not in_own_pid_namespace(pid):
            unseen.append(f"pid {pid} names it but lives in another PID namespace (a container)")
        elif not on_this_host(pid):
            unseen.append(f"pid {pid} names it but lives in another network namespace (a host)")
        else:
            copies.append(Copy(pid, "its command line names it"))
    return copies, unseen


def _live(pid: int) -> psutil.Process | None:
    try:
        proc = psutil.Process(pid)
        return proc if proc.status() != psutil.STATUS_ZOMBIE else None
    except psutil.Error:
        return None


def _running(proc: psutil.Process) -> bool:
    try:
        return proc.is_running() and proc.status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False


def stop_copies(
    copies: Sequence[Copy], steps: Sequence[tuple[int, float]] = STOP_STEPS
) -> tuple[list[Copy], str, list[str]]:
    """Signal each copy (the outermost of related ones; a session racc started as a whole)
    with each signal in turn until all are gone: (those still alive, the last signal sent,
    signals that could not be sent)."""
    live = {c.pid: (c, p) for c in copies if (p := _live(c.pid)) is not None}
    failed: list[str] = []
    sent = ""
    for sig, wait_s in steps:
        procs = [p for _, p in live.values() if _running(p)]
        if not procs:
            break
        # SIGKILL to every one of them; a polite signal to the outermost (a wrapper such as
        # rosrun or ros2 run passes it on, and its child must not get it twice).
        targets = procs if sig == signal.SIGKILL else outermost(procs)
        sent = signal.Signals(sig).name
        for proc in targets:
            copy = live[proc.pid][0]
            try:
                if copy.session:
                    os.killpg(proc.pid, sig)
                else:
                    proc.send_signal(sig)
            except (OSError, psutil.Error) as err:
                failed.append(f"{sent} to pid {proc.pid}: {err}")
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline and any(_running(p) for p in procs):
            time.sleep(0.05)
    alive = [c for c, p in live.values() if _running(p)]
    return alive, sent, failed


def prove_gone(
    node: str,
    copies: Sequence[Copy],
    unseen: Sequence[str],
    steps: Sequence[tuple[int, float]] = STOP_STEPS,
) -> str | None:
    """Stop every live copy of ``node`` and prove it gone; a note for the log when one was
    alive (None: none was).  RAC156 when a copy cannot be stopped from here, RAC155 when one
    survives; nothing is stopped when one cannot be reached."""
    if unseen:
        raise RacError(
            [
                Diagnostic(
                    "RAC156",
                    f"not starting '{node}': an old process of it may still run where racc "
                    f"cannot stop it ({'; '.join(unseen)}); never two copies",
                    hint="stop the old process where it runs (its container, its machine), or "
                    "run racc's agent there (racc observe --machine NAME --launch FILE); the "
                    "next repair starts the node once no copy of it is left",
                )
            ]
        )
    live = [c for c in copies if _live(c.pid) is not None]
    if not live:
        return None
    alive, sent, failed = stop_copies(live, steps)
    pids = ", ".join(f"pid {c.pid} ({c.how})" for c in live)
    if alive:
        why = f"; {'; '.join(failed)}" if failed else ""
        raise RacError(
            [
                Diagnostic(
                    "RAC155",
                    f"not starting '{node}': its old process {pids} was still alive and "
                    f"did not stop (SIGINT, SIGTERM, SIGKILL){why}; never two copies",
                    hint=f"stop it by hand ('kill -9 {alive[0].pid}'; a process another user "
                    "runs needs that user or root); the next repair starts the node",
                )
            ]
        )
    return (
        f"the old process {pids} of {node} was still alive: stopped it first ({sent}); "
        "never two copies"
    )
