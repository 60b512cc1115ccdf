"""The guardian of a node racc started: the robot's lifetime bounds the node's (issue 34).

A node the repairer starts runs in a session of its own, so that stopping racc does not stop
the robot (:mod:`rac.runtime.detached`).  Without a bound it would outlive the robot too:
after the robot's launch and its master stopped, a restarted motor driver would keep
running.  So racc starts each node through a guardian, a small process detached from racc
that starts the node (its child, in a session of the node's own) and stops it when the robot
stops:

- the robot's launch process ended (``roslaunch``, ``ros2 launch`` or ``racc demo`` of the
  robot's launch file, found by racc when it started the node; known by its pid and its
  start time, so that a new process that reuses the pid is not taken for it);
- ROS 1: the robot's master has accepted no connection for ``gone_s`` (a master restart of
  a few seconds does not stop the node);
- ROS 2: none of the robot's other local nodes (a process whose command line says
  ``__node:=`` one of their names, in the node's ROS 2 domain, not started by racc) has run
  for ``gone_s``: once one was seen, or from the start when no launch process was found.

Stopping is SIGINT to the node's session, then SIGTERM, then SIGKILL (:data:`STOP_STEPS`).
The guardian exits when its node exits, whatever ended it; SIGTERM, SIGINT or SIGHUP to the
guardian stops the node first.  Its decisions go to the node's log file (``racc guardian:``
lines).

It imports only the standard library, and racc runs it as a script (``python -I -S
guardian.py``, not ``-m rac.runtime.guardian``, which would import the package ``rac``
first): one guardian costs about as much memory as a bare Python interpreter.  It reads
what to do as one JSON object (:class:`Orders`) on its stdin and answers ``pid N`` (the
node's) or ``error TEXT`` on its stdout, which it then closes.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Sequence

GUARDIAN_ENV = "RACC_GUARDIAN_PID"  # in a guarded node's environment: the guardian's pid
DEFAULT_GONE_S = 30.0
# (signal, seconds to wait for the node after it): as roslaunch stops a node, shorter
STOP_STEPS = ((signal.SIGINT, 5.0), (signal.SIGTERM, 3.0), (signal.SIGKILL, 2.0))
POLL_S = 0.25  # the node's exit and the launch process
SLOW_POLL_S = 1.0  # the master and the other nodes


# -- processes, from /proc (no psutil here) ---------------------------------------------------


def process_start(pid: int) -> int | None:
    """The start time of a live process (clock ticks since boot, field 22 of /proc/PID/stat);
    None when there is no such process or it is a zombie (it has ended)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read()
    except OSError:
        return None
    fields = stat[stat.rfind(b")") + 2 :].split()  # after "pid (comm) "
    if len(fields) < 20 or fields[0] in (b"Z", b"X"):
        return None
    return int(fields[19])


def command_line(pid: int | str) -> list[str]:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            raw = f.read()
    except OSError:
        return []
    return [a.decode("utf-8", "replace") for a in raw.split(b"\0")[:-1]]


def remaps_node(cmdline: Sequence[str], base: str, ns: str) -> bool:
    """The command line names the ROS 2 node ``ns/base``: ``__node:=base`` and, for a node in
    a namespace, its last ``__ns:=``."""
    if f"__node:={base}" not in cmdline:
        return False
    wanted = "/" + ns.strip("/")
    spaces = [a.partition(":=")[2] for a in cmdline if a.startswith("__ns:=")]
    return (spaces[-1] if spaces else "/").rstrip("/") == wanted.rstrip("/")


def environ(pid: int | str) -> dict[str, str] | None:
    """The environment a process started with (None: not ours to read, or gone)."""
    try:
        with open(f"/proc/{pid}/environ", "rb") as f:
            raw = f.read()
    except OSError:
        return None
    pairs = (entry.decode("utf-8", "replace").partition("=") for entry in raw.split(b"\0"))
    return {k: v for k, _, v in pairs if k}


def node_pids(
    names: Sequence[str], domain: str | None = None, exclude: frozenset[int] = frozenset()
) -> dict[int, int]:
    """Live processes (pid -> start) of this machine whose command line names one of the ROS
    2 nodes ``names`` ("ns/name" or "name"), in the ROS 2 domain ``domain`` (None: any),
    but for racc's guarded ones and ``exclude``.  A process whose environment cannot be read
    counts."""
    wanted = [(n.strip("/").rpartition("/")[2], n.strip("/").rpartition("/")[0]) for n in names]
    found: dict[int, int] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return found
    for entry in entries:
        if not entry.isdigit() or int(entry) in exclude:
            continue
        line = command_line(entry)
        if not any(a.startswith("__node:=") for a in line):
            continue
        if not any(remaps_node(line, base, ns) for base, ns in wanted):
            continue
        env = environ(entry)
        if env is not None and (
            GUARDIAN_ENV in env
            or (domain is not None and (env.get("ROS_DOMAIN_ID") or "0") != domain)
        ):
            continue  # a node racc started, or a node of another robot's domain
        start = process_start(int(entry))
        if start is not None:
            found[int(entry)] = start
    return found


def host_port(uri: str) -> tuple[str, int] | None:
    """The host and port of ``http://HOST:PORT/`` (urllib.parse costs the guardian memory)."""
    netloc = uri.partition("://")[2].partition("/")[0].rpartition("@")[2]
    host, _, port = netloc.rpartition(":")
    host = host.strip("[]")
    return (host, int(port)) if host and port.isdigit() else None


def master_answers(uri: str, timeout_s: float = 1.0) -> bool:
    """The ROS master at ``uri`` accepts a TCP connection (a busy master still does)."""
    address = host_port(uri)
    if address is None:
        return False
    try:
        with socket.create_connection(address, timeout=timeout_s):
            return True
    except OSError:
        return False


# -- what the guardian is told ----------------------------------------------------------------


class Orders:
    """What to start and when to stop it (the JSON object on the guardian's stdin).  A plain
    class: importing dataclasses would double the guardian's own memory."""

    __slots__ = (
        "argv",
        "cwd",
        "env",
        "gone_s",
        "launch_pid",
        "launch_start",
        "launch_what",
        "log",
        "master_uri",
        "node",
        "others",
        "others_from_start",
        "poll_s",
        "slow_poll_s",
        "stop_steps",
    )

    def __init__(
        self,
        argv: Sequence[str],
        env: dict[str, str],
        log: str,  # the node's log file: its output and the guardian's lines
        node: str = "",
        cwd: str | None = None,
        launch_pid: int | None = None,  # the robot's launch process
        launch_start: int | None = None,  # its start (process_start), against pid reuse
        launch_what: str = "",  # e.g. "roslaunch of /robot/robot.launch"
        master_uri: str | None = None,  # ROS 1
        others: Sequence[str] = (),  # ROS 2: the robot's other nodes
        others_from_start: bool = False,  # count their absence from the start
        gone_s: float = DEFAULT_GONE_S,
        stop_steps: Sequence[tuple[int, float]] = STOP_STEPS,
        poll_s: float = POLL_S,
        slow_poll_s: float = SLOW_POLL_S,
    ) -> None:
        self.argv = tuple(argv)
        self.env = dict(env)
        self.log = log
        self.node = node
        self.cwd = cwd
        self.launch_pid = launch_pid
        self.launch_start = launch_start
        self.launch_what = launch_what
        self.master_uri = master_uri
        self.others = tuple(others)
        self.others_from_start = bool(others_from_start)
        self.gone_s = float(gone_s)
        self.stop_steps = tuple((int(sig), float(wait)) for sig, wait in stop_steps)
        self.poll_s = float(poll_s)
        self.slow_poll_s = float(slow_poll_s)

    def to_json(self) -> str:
        return json.dumps({k: getattr(self, k) for k in self.__slots__})

    @classmethod
    def from_json(cls, text: str) -> Orders:
        return cls(**json.loads(text))


# -- the watch -------------------------------------------------------------------------------


class Watch:
    """The robot's lifetime, as the guardian sees it: :meth:`why_stop` says why the node
    must stop now (None: it may run on).  Pure but for ``master`` and ``nodes``, which a
    test replaces."""

    def __init__(
        self,
        orders: Orders,
        now: float,
        master: Callable[[str], bool] = master_answers,
        nodes: Callable[[Sequence[str], str | None], dict[int, int]] = node_pids,
        start_of: Callable[[int], int | None] = process_start,
    ) -> None:
        self.orders = orders
        self.master, self.nodes, self.start_of = master, nodes, start_of
        self.master_seen = now  # the master was there when racc started the node
        self.others: dict[int, int] = {}  # the robot's other nodes seen running: pid -> start
        # When one last ran (None: never seen, and the absence is not counted).  Without a
        # launch process the absence counts from the start: a node started while none of
        # the robot runs here (a repair racing the robot's shutdown) must not run forever.
        self.others_seen: float | None = now if orders.others_from_start else None
        self._next_slow = now

    def why_stop(self, now: float) -> str | None:
        o = self.orders
        if o.launch_pid is not None and self.start_of(o.launch_pid) != o.launch_start:
            return f"the robot's launch process ended ({o.launch_what}, pid {o.launch_pid})"
        if now < self._next_slow:
            return None
        self._next_slow = now + o.slow_poll_s
        if o.master_uri is not None:
            if self.master(o.master_uri):
                self.master_seen = now
            elif now - self.master_seen >= o.gone_s:
                return (
                    f"the ROS master at {o.master_uri} has been gone for "
                    f"{now - self.master_seen:.1f} s (more than {o.gone_s:g} s)"
                )
        if o.others:
            return self._others(now)
        return None

    def _others(self, now: float) -> str | None:
        o = self.orders
        # The ones seen before, while one still runs: no scan of the process table.
        self.others = {p: s for p, s in self.others.items() if self.start_of(p) == s}
        if not self.others:
            self.others = self.nodes(o.others, o.env.get("ROS_DOMAIN_ID") or "0")
        if self.others:
            self.others_seen = now
            return None
        if self.others_seen is not None and now - self.others_seen >= o.gone_s:
            return (
                f"none of the robot's other nodes has run here for "
                f"{now - self.others_seen:.1f} s (more than {o.gone_s:g} s)"
            )
        return None

    def conditions(self) -> str:
        """What stops the node, for the log."""
        o = self.orders
        out = []
        if o.launch_pid is not None:
            out.append(f"the robot's launch process ends ({o.launch_what}, pid {o.launch_pid})")
        if o.master_uri is not None:
            out.append(f"the ROS master at {o.master_uri} is gone for {o.gone_s:g} s")
        if o.others:
            since = " (counted from now)" if o.others_from_start else ""
            out.append(f"none of the robot's other nodes has run here for {o.gone_s:g} s{since}")
        return "; or ".join(out) or "nothing (no launch process, master or other node known)"


def stop(pid: int, steps: Sequence[tuple[int, float]], exited: Callable[[], bool]) -> str:
    """Signal the node's session with each signal in turn until it has exited; what it took."""
    for sig, wait_s in steps:
        with contextlib.suppress(OSError):
            os.killpg(pid, sig)
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline:
            if exited():
                return f"stopped by {signal.Signals(sig).name}"
            time.sleep(0.05)
    return "still running after SIGKILL"


def _say(text: str) -> None:
    print(f"t={time.time():.3f} racc guardian {os.getpid()}: {text}", flush=True)


def guard(orders: Orders, answer: Callable[[str], None]) -> int:
    """Start the node, answer its pid, watch, stop it when the robot stops; the exit code."""
    env = {**orders.env, GUARDIAN_ENV: str(os.getpid())}
    stopping: list[str] = []  # set before the node starts: no signal may orphan it

    def on_signal(signum: int, _frame: object) -> None:
        stopping.append(f"the guardian got {signal.Signals(signum).name}")

    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        signal.signal(sig, on_signal)
    try:
        with open(orders.log, "ab") as out:
            node = subprocess.Popen(
                list(orders.argv),
                env=env,
                cwd=orders.cwd,
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=subprocess.STDOUT,
                start_new_session=True,
                close_fds=True,
            )
    except (OSError, ValueError) as err:
        answer(f"error {err}")
        return 1
    answer(f"pid {node.pid}")
    watch = Watch(orders, time.monotonic())
    name = orders.node or "the node"
    _say(f"guarding {name} (pid {node.pid}): stopped when {watch.conditions()}")
    while True:
        code = node.poll()
        if code is not None:
            _say(f"{name} (pid {node.pid}) exited ({code}): done")
            return 0
        why = stopping[0] if stopping else watch.why_stop(time.monotonic())
        if why is not None:
            _say(f"the robot stopped: {why}; stopping {name} (pid {node.pid})")
            how = stop(node.pid, orders.stop_steps, lambda: node.poll() is not None)
            _say(f"{name} (pid {node.pid}) {how}")
            return 0 if node.poll() is not None else 1
        time.sleep(orders.poll_s)


def main() -> int:
    orders = Orders.from_json(sys.stdin.read())
    with open(orders.log, "ab", buffering=0) as log:

        def answer(text: str) -> None:
            sys.stdout.write(text + "\n")
            sys.stdout.flush()
            # From now on the guardian's own lines go to the node's log, not to racc.
            os.dup2(log.fileno(), 1)
            os.dup2(log.fileno(), 2)

        return guard(orders, answer)


if __name__ == "__main__":
    sys.exit(main())
