"""Node liveness and cpu/mem samples, from the operating system's process table.

A transport gives a ``resolve(node)`` that asks its middleware for the node (ROS 1: the
master's lookupNode, then the node's getPid) and returns a :class:`Found` (the node is
there: a local process proven to be the node's, or no trusted process at all), or None when
the node is not there (a bare pid, or REMOTE for another machine, are accepted too).  Once a
proven pid is known, liveness and properties come from psutil without asking the middleware
again; a node whose process has gone is resolved afresh (a restarted node has a new pid).
A node without a proven process is asked for again every ``resolve_every_s`` and has no
cpu or memory samples: its properties stay unknown (:mod:`rac.runtime.placement`).

A process is judged by its cpu and memory only once it has run ``settle_s``
(:data:`DEFAULT_SETTLE_S`): a node's start-up (a Python node importing its libraries, a
driver loading its configuration) keeps a core busy and grows its memory for a second or
more, which against a limit of a few percent reads as an overload at every start, and
after every repair that restarted the node.  Liveness is judged from the first moment.

ROS 2 has no getPid: a node's process is found in the process table by the ``__node:=NAME``
remapping on its command line (:func:`node_processes`), which ``ros2 launch``, ``ros2 run
... --ros-args -r __node:=NAME``, ``racc demo`` and ``racc repairer`` all put there.
"""

from __future__ import annotations

import contextlib
import os
import signal
import time
from collections.abc import Callable, Iterable, Sequence

import psutil

from rac.observe import Event, NodeSample, PropertySample
from rac.runtime.guardian import remaps_node
from rac.runtime.placement import Found

REMOTE = -1
# The middleware did not answer in time (ROS 1: getPid or the master's lookupNode timed
# out) and no local process of the node is proven: a busy node, not a dead one.  Its last
# answer stands for UNANSWERED_HOLD_S; then whether it runs is unknown (its ``running``
# atom is withdrawn) until it answers or refuses: a slow answer is not an absent process.
UNANSWERED = -2
UNANSWERED_HOLD_S = 2.0
DEFAULT_SETTLE_S = 5.0  # a process's start-up is not its steady state
Resolved = int | Found | None


GONE = Found(None, "it answers no more: the master does not have it, or its server refused")


def _silent(for_s: float) -> str:
    return (
        f"no answer for {for_s:.1f} s, and no local process of it is proven (none holds its "
        "XML-RPC port or names it): whether it runs is unknown until it answers or refuses"
    )


def as_found(resolved: Resolved) -> Found | None:
    """A resolver's answer as a :class:`Found` (a bare pid is taken as proven)."""
    if resolved is None or isinstance(resolved, Found):
        return resolved
    if resolved == UNANSWERED:  # nothing learnt (ProcessProbe._ask holds the last answer)
        return None
    if resolved == REMOTE:
        return Found(None, "on another machine")
    return Found(resolved, f"pid {resolved}")


def seconds_since_boot() -> float:
    """The clock a process's start is counted on (Linux: CLOCK_BOOTTIME, which no change
    of the wall clock moves)."""
    if hasattr(time, "CLOCK_BOOTTIME"):
        return time.clock_gettime(time.CLOCK_BOOTTIME)
    return time.time() - psutil.boot_time()


def started_since_boot(proc: psutil.Process) -> float:
    """When ``proc`` started, in seconds since boot.  psutil's create_time adds the boot
    time of /proc/stat, in whole seconds, to the exact start since boot: as an epoch time it
    is up to 1 s early, and the difference takes that error out again."""
    return proc.create_time() - psutil.boot_time()


class ProcessProbe:
    def __init__(
        self,
        nodes: Iterable[str],
        resolve: Callable[[str], Resolved],
        properties: Iterable[tuple[str, str]] = (),
        resolve_every_s: float = 0.5,
        recheck_s: float | None = None,
        settle_s: float = DEFAULT_SETTLE_S,
        since_boot: Callable[[], float] | None = None,
    ) -> None:
        self.nodes = tuple(sorted(set(nodes) | {n for n, _ in properties}))
        self.properties = frozenset(properties)
        self.resolve = resolve
        self.resolve_every_s = resolve_every_s
        # ROS 2: a node's process is found by its command line, and a starting node's
        # process matches before its real one does (a wrapper, a demo node's body): a live
        # process is resolved again every ``recheck_s`` and replaced when another answers.
        self.recheck_s = recheck_s
        self.settle_s = settle_s
        self.since_boot = since_boot or seconds_since_boot
        # node -> when its process has settled (since boot); written whenever one is adopted
        self._settles_at: dict[str, float] = {}
        self._procs: dict[str, psutil.Process] = {}
        self._born: dict[str, float] = {}  # node -> its process's start (psutil's)
        self._asked: dict[str, float] = {}  # when the middleware was last asked
        self._alive: dict[str, bool] = {}
        self._unanswered: dict[str, float] = {}  # since when the middleware has not answered
        self.placement: dict[str, Found] = {}  # how each node is watched, as last resolved
        self._moved: list[tuple[str, Found]] = []  # placements changed since last taken

    def _place(self, node: str, found: Found) -> None:
        old = self.placement.get(node)
        if old is None or old.watched != found.watched or old.how != found.how:
            self.placement[node] = found
            self._moved.append((node, found))

    def take_placements(self) -> list[tuple[str, Found]]:
        """Nodes whose way of being watched changed (for the log and ``/observations``)."""
        out, self._moved = self._moved, []
        return out

    def unknown(self, node: str) -> bool:
        """Whether the node runs is unknown: the middleware has not answered for it for
        ``UNANSWERED_HOLD_S`` and no local process of it is proven."""
        found = self.placement.get(node)
        return found is not None and found.unknown

    def running(self, node: str) -> bool | None:
        """Whether the node ran at its latest sample (None: not judged)."""
        return self._alive.get(node)

    def pid(self, node: str) -> int | None:
        proc = self._procs.get(node)
        return proc.pid if proc is not None else None

    def _local(self, node: str) -> psutil.Process | None:
        proc = self._procs.get(node)
        if proc is None:
            return None
        try:
            # The state, and the start time that tells a reused pid from the node's
            # process (what is_running checks, with a second Process object).
            if proc.status() != psutil.STATUS_ZOMBIE and proc.create_time() == self._born[node]:
                return proc
        except psutil.Error:
            pass
        del self._procs[node]
        return None

    def _ask(self, node: str, t: float) -> bool | None:
        """Ask the middleware (at most every ``resolve_every_s``); None: not asked now, or
        not answered in time, which leaves the last answer standing for up to
        ``UNANSWERED_HOLD_S`` (like a liveness probe's failure threshold: one slow answer
        of a node on a loaded machine is no crash); then whether the node runs is unknown
        (:meth:`unknown`) until it answers, or refuses (gone)."""
        if t - self._asked.get(node, float("-inf")) < self.resolve_every_s:
            return None
        self._asked[node] = t
        resolved = self.resolve(node)
        last = self.placement.get(node)
        if isinstance(resolved, int) and resolved == UNANSWERED:
            if last is not None and last.pid is not None:
                return False  # its proven process is gone: no answer brings it back
            since = self._unanswered.setdefault(node, t)
            if t - since >= UNANSWERED_HOLD_S:
                self._alive.pop(node, None)  # no sample until it answers
                if last is None or not last.unknown:
                    self._place(node, Found(None, _silent(t - since), unknown=True))
            return None
        self._unanswered.pop(node, None)
        found = as_found(resolved)
        if found is None:
            if last is not None and last.unknown:
                self._place(node, GONE)
            return False
        if found.pid is not None:
            try:
                self._adopt(node, found.pid)
            except psutil.Error:
                return False
        self._place(node, found)
        return True

    def _adopt(self, node: str, pid: int) -> psutil.Process:
        """Watch ``pid`` as the node's process from now on (raises psutil.Error)."""
        proc = psutil.Process(pid)
        proc.cpu_percent(None)  # the first call only starts the measurement
        self._born[node] = proc.create_time()
        # Once per process: psutil's boot time reads /proc/stat at every call.
        self._settles_at[node] = started_since_boot(proc) + self.settle_s
        self._procs[node] = proc
        return proc

    def _recheck(self, node: str, proc: psutil.Process, t: float) -> psutil.Process | None:
        assert self.recheck_s is not None
        if t - self._asked.get(node, float("-inf")) < self.recheck_s:
            return proc
        self._asked[node] = t
        found = as_found(self.resolve(node))
        if found is None or found.pid == proc.pid:
            return proc
        if found.pid is None:  # the process is no longer proven to be the node's
            del self._procs[node]
            self._place(node, found)
            return None
        try:
            fresh = self._adopt(node, found.pid)
        except psutil.Error:
            return proc
        self._place(node, found)
        return fresh

    def sample(self, t: float, with_properties: bool = True) -> list[Event]:
        """A liveness sample of every node that can be judged now, and its properties."""
        out: list[Event] = []
        booted_s = self.since_boot()
        for node in self.nodes:
            proc = self._procs.get(node)
            # One read of /proc/PID/stat serves the liveness check and the cpu time (at
            # 100 nodes ten times a second, the reads are most of the host's own cost).
            with proc.oneshot() if proc is not None else contextlib.nullcontext():
                out += self._sample_node(node, t, booted_s, with_properties)
        return out

    def _sample_node(
        self, node: str, t: float, booted_s: float, with_properties: bool
    ) -> list[Event]:
        proc = self._local(node)
        if proc is not None and self.recheck_s is not None:
            proc = self._recheck(node, proc, t)
        running: bool | None
        if proc is not None:
            running = True
        else:
            running = self._ask(node, t)
            if running is None:  # asked a moment ago: the answer stands until next time
                running = self._alive.get(node)
            proc = self._local(node) if running else None
        if running is None:
            return []
        self._alive[node] = running
        out: list[Event] = [NodeSample(t, node, running)]
        if proc is None or not with_properties:
            return out
        try:
            out += self._properties(node, proc, t, booted_s)
        except psutil.Error:
            self._procs.pop(node, None)
        return out

    def _properties(
        self, node: str, proc: psutil.Process, t: float, booted_s: float
    ) -> list[Event]:
        """The node's cpu and memory samples at ``booted_s`` since boot; none while its
        process is settling."""
        # cpu is read in every tick, settling or not: each reading covers the time since
        # the one before, so the first judged one must not reach back into the start-up.
        cpu = proc.cpu_percent(None) if (node, "cpu") in self.properties else None
        if booted_s < self._settles_at[node]:
            return []
        out: list[Event] = []
        if cpu is not None:
            out.append(PropertySample(t, node, "cpu", cpu))
        if (node, "mem") in self.properties:
            out.append(PropertySample(t, node, "mem", float(proc.memory_info().rss)))
        return out


# -- processes by their ROS 2 command line -------------------------------------------------


def node_processes(
    node: str, table: Sequence[psutil.Process] | None = None
) -> list[psutil.Process]:
    """Live processes whose command line remaps the node name to ``node`` ("ns/name" or
    "name"), oldest first; ``table``: a :func:`process_table` to search."""
    ns, _, base = node.strip("/").rpartition("/")
    found = []
    for proc in process_table() if table is None else table:
        if remaps_node(proc.info["cmdline"], base, ns):
            found.append(proc)
    return sorted(found, key=lambda p: (p.info["create_time"], p.pid))


YOUNG_S = 5.0  # a process this young may still exec (a fork's command line is its parent's)


class ProcessTable:
    """:func:`process_table`, kept between scans: a scan lists ``/proc`` and reads the
    command line only of processes it has not seen (and of young ones, which may exec),
    rather than three files of every process of the machine (at 100 nodes, a scan a
    second was a fifth of the observer host's own cost).  A listed process may have ended
    or been replaced since (a reused pid): the caller checks the one it uses
    (``is_running``), and :meth:`forget` drops it."""

    def __init__(self, clock: Callable[[], float] = time.time) -> None:
        self.clock = clock
        self._known: dict[int, psutil.Process] = {}

    def scan(self) -> list[psutil.Process]:
        now = self.clock()
        try:
            pids = set(psutil.pids())
        except OSError:
            return list(self._known.values())
        for pid in [p for p in self._known if p not in pids]:
            del self._known[pid]
        out = []
        for pid in pids:
            proc = self._known.get(pid)
            if proc is None or now - proc.info["create_time"] < YOUNG_S:
                proc = self._read(pid)
                if proc is None:
                    continue
                self._known[pid] = proc
            if proc.info["cmdline"] and any(a.startswith("__node:=") for a in proc.info["cmdline"]):
                out.append(proc)
        return out

    def forget(self, proc: psutil.Process) -> None:
        if self._known.get(proc.pid) is proc:
            del self._known[proc.pid]

    @staticmethod
    def _read(pid: int) -> psutil.Process | None:
        try:
            proc = psutil.Process(pid)
            proc.info = {"cmdline": proc.cmdline(), "create_time": proc.create_time()}
        except psutil.Error:
            return None
        return proc


def index_by_node(table: Sequence[psutil.Process]) -> dict[tuple[str, str], list[psutil.Process]]:
    """A :func:`process_table` by the node each command line names: ("name", "/ns") -> its
    processes, oldest first (as :func:`node_processes` finds them, for every node at once)."""
    index: dict[tuple[str, str], list[psutil.Process]] = {}
    for proc in table:
        cmdline = proc.info["cmdline"]
        spaces = [a.partition(":=")[2] for a in cmdline if a.startswith("__ns:=")]
        ns = (spaces[-1] if spaces else "/").rstrip("/") or "/"
        for arg in cmdline:
            if arg.startswith("__node:="):
                index.setdefault((arg.partition(":=")[2], ns), []).append(proc)
    for procs in index.values():
        procs.sort(key=lambda p: (p.info["create_time"], p.pid))
    return index


def node_key(node: str) -> tuple[str, str]:
    """("name", "/ns") of a node "ns/name" or "name", as :func:`index_by_node` keys it."""
    ns, _, base = node.strip("/").rpartition("/")
    return base, ("/" + ns.strip("/")).rstrip("/") or "/"


def process_table() -> list[psutil.Process]:
    """Live processes that may be ROS 2 nodes (their command line has a ``__node:=``)."""
    out = []
    for proc in psutil.process_iter(["cmdline", "status", "create_time"]):
        info = proc.info
        if info["status"] == psutil.STATUS_ZOMBIE or not info["cmdline"]:
            continue
        if any(a.startswith("__node:=") for a in info["cmdline"]):
            out.append(proc)
    return out


def _ancestors(proc: psutil.Process) -> set[int]:
    try:
        return {p.pid for p in proc.parents()}
    except psutil.Error:
        return set()


def innermost(procs: Sequence[psutil.Process]) -> psutil.Process | None:
    """The match no other match descends from (the newest of several).  ``ros2 run``, a
    shell or a launch prefix carries the same arguments as the process it starts; the
    innermost one is the node itself (for ``racc demo``: its driver-sized body)."""
    inner = [p for p in procs if not any(p.pid in _ancestors(q) for q in procs if q is not p)]
    return inner[-1] if inner else None


def outermost(procs: Sequence[psutil.Process]) -> list[psutil.Process]:
    """The matches no other match started: what to signal to stop the node."""
    pids = {p.pid for p in procs}
    return [p for p in procs if not (_ancestors(p) & (pids - {p.pid}))]


def alive(pid: int) -> bool:
    try:
        return bool(psutil.Process(pid).status() != psutil.STATUS_ZOMBIE)
    except psutil.Error:
        return False


def terminate(pid: int, signals: Sequence[int | None], grace_s: float = 1.5) -> None:
    """Each signal in turn (None: only wait) until the process is gone, ``grace_s`` apart."""
    for sig in signals:
        if not alive(pid):
            return
        if sig is not None:
            try:
                os.kill(pid, sig)
            except OSError:
                return
        deadline = time.time() + grace_s
        while time.time() < deadline:
            if not alive(pid):
                return
            time.sleep(0.05)


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGKILL)
