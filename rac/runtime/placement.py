"""Whose process is a node's: the proof that a pid belongs to a node, or why none exists.

A node's process is watched (liveness from the process table, cpu and memory) only when
it is proven to be the node's: the pid is one of this PID namespace and this host (this
network namespace), and the process holds
the node's XML-RPC port (ROS 1) or its command line names the node (``__name:=`` or
``__node:=``).  A node whose pid cannot be trusted is watched through the middleware alone
(the master or the graph, and its topics): its liveness is what the middleware says, and
its cpu and memory are unknown, never ``ok``.

The pid a ROS 1 node answers to ``getPid`` is counted in the node's own PID namespace: a
node in a container answers 1, and this host's process 1 is the init process.  That is why
a pid alone proves nothing.
"""

from __future__ import annotations

import os
import socket
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import psutil

from rac.logic import Atom
from rac.passes.observers import ObserverSpec
from rac.runtime.guardian import host_port


@dataclass(frozen=True, slots=True)
class Found:
    """What the middleware and the process table say of a node that is there.

    ``pid``: a process of this host, proven to be the node's (None: the node is watched
    through the middleware only); ``how``: the proof, or why there is none, for the log and
    for ``/observations``."""

    pid: int | None
    how: str
    # Whether the node runs is not known: the middleware does not answer for it and no
    # local process of it is proven (a slow answer is not an absent process).
    unknown: bool = False

    @property
    def watched(self) -> str:
        """The value ``watched`` on the node's ``/observations`` row."""
        if self.unknown:
            return "unknown"
        return "process" if self.pid is not None else "middleware"


def pid_namespace(pid: int | str, kind: str = "pid") -> str | None:
    """``pid:[inode]`` of a process's PID namespace (``kind`` "net": ``net:[inode]``, its
    network namespace); None: not readable."""
    try:
        return os.readlink(f"/proc/{pid}/ns/{kind}")
    except OSError:
        return None


def own_pid_namespace() -> str | None:
    return pid_namespace("self")


def in_own_pid_namespace(pid: int) -> bool:
    """The process ``pid`` of this process table shares this process's PID namespace.  A
    process in a child namespace (a container seen from its host) has another number
    inside, so a pid it reports about itself is not ours."""
    own = own_pid_namespace()
    return own is not None and pid_namespace(pid) == own


def on_this_host(pid: int) -> bool:
    """The process shares this process's network namespace: the same host as far as the
    middleware is concerned (a container with its own network, or a second computer
    simulated by a network namespace, is another host)."""
    own = pid_namespace("self", "net")
    return own is not None and pid_namespace(pid, "net") == own


def listening_inodes(port: int) -> set[str]:
    """The inodes of the sockets listening on TCP ``port`` in this network namespace (from
    /proc/net/tcp and tcp6: one read each, where psutil builds every connection of the
    machine, about 100 ms on a busy one)."""
    want = f":{port:04X} "
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            with open(table, encoding="ascii") as f:
                next(f, None)
                for line in f:
                    fields = line.split()
                    # local address, state 0A (LISTEN), inode
                    if len(fields) > 9 and (fields[1] + " ").endswith(want) and fields[3] == "0A":
                        found.add(fields[9])
        except OSError:
            continue
    return found


def _socket_fds(pid: int | str) -> set[str]:
    """The ``socket:[INODE]`` links among the process's open files (none when it is gone or
    not ours to read)."""
    fd_dir = f"/proc/{pid}/fd"
    try:
        fds = os.listdir(fd_dir)
    except OSError:
        return set()
    links = set()
    for fd in fds:
        try:
            links.add(os.readlink(f"{fd_dir}/{fd}"))
        except OSError:
            continue
    return links


def holds_port(pid: int, port: int) -> bool:
    """The process listens on TCP ``port`` (a ROS 1 node's XML-RPC server)."""
    inodes = {f"socket:[{i}]" for i in listening_inodes(port)}
    return bool(inodes) and not inodes.isdisjoint(_socket_fds(pid))


def listening_pid(port: int) -> int | None:
    """The local process that listens on TCP ``port`` (a ROS 1 node's XML-RPC server),
    found without asking it: a frozen node does not answer ``getPid``.  The repairer kills
    a frozen node by it."""
    inodes = {f"socket:[{i}]" for i in listening_inodes(port)}
    if not inodes:
        return None
    for entry in os.listdir("/proc"):
        if entry.isdigit() and not inodes.isdisjoint(_socket_fds(entry)):
            return int(entry)
    return None


def names_node(cmdline: Sequence[str], node: str) -> bool:
    """The command line remaps the node's name to it (``__name:=`` in ROS 1, ``__node:=``
    in ROS 2; the namespace is not checked: ROS_NAMESPACE may carry it)."""
    base = node.strip("/").rpartition("/")[2]
    return f"__name:={base}" in cmdline or f"__node:={base}" in cmdline


def cmdline(pid: int) -> list[str]:
    try:
        return list(psutil.Process(pid).cmdline())
    except psutil.Error:
        return []


def prove_ros1(node: str, pid: int, port: int | None) -> Found:
    """The pid a local ROS 1 node answered to ``getPid``, trusted or not."""
    if not psutil.pid_exists(pid):
        return Found(None, f"getPid answered {pid}, which is no process here")
    if not in_own_pid_namespace(pid):
        return Found(None, f"getPid answered {pid}, a process of another PID namespace")
    if not on_this_host(pid):
        return Found(None, f"getPid answered {pid}, a process of another network namespace")
    # The command line first: reading it costs a fraction of finding a port's socket.
    if names_node(cmdline(pid), node):
        return Found(pid, f"pid {pid}'s command line names it")
    if port is not None and holds_port(pid, port):
        return Found(pid, f"pid {pid} holds its XML-RPC port {port}")
    return Found(
        None,
        f"getPid answered {pid}, which neither holds its XML-RPC port {port} nor names it "
        "(a node in a container or another PID namespace)",
    )


def silent_ros1(node: str, port: int | None) -> Found | None:
    """A local ROS 1 node whose XML-RPC server did not answer ``getPid`` in time (busy,
    or frozen): its process found without asking it, by the XML-RPC port the master has for
    it (``port``; None: not of this machine, or not known) or else by the one process tree
    whose command line names it.  None when no process of it can be proven."""
    why = "getPid did not answer in time"
    pid = listening_pid(port) if port is not None else None
    if pid is not None and in_own_pid_namespace(pid) and on_this_host(pid):
        return Found(pid, f"{why}; pid {pid} holds its XML-RPC port {port}")
    named = ros1_named(node, unreadable=False, graph=ros_graph(os.environ, 1))
    pids = {p.pid for p in named}
    outer = [p for p in named if not (_parents(p) & (pids - {p.pid}))]
    if len(outer) != 1:  # none, or several nodes of that name (namespaces): no proof
        return None
    # One tree (a wrapper such as rosrun and the node it runs): the innermost is the node.
    pid = max(named, key=lambda p: len(_parents(p))).pid
    if not (in_own_pid_namespace(pid) and on_this_host(pid)):
        return None
    return Found(pid, f"{why}; pid {pid}'s command line names it")


def _namespace(proc: psutil.Process, cmdline: Sequence[str]) -> str | None:
    """A ROS 1 process's namespace: its last ``__ns:=``, else its ROS_NAMESPACE (roslaunch
    passes a group's namespace so), else "/"; None when its environment cannot be read
    (another user's process)."""
    spaces = [a.partition(":=")[2] for a in cmdline if a.startswith("__ns:=")]
    if spaces:
        return "/" + spaces[-1].strip("/")
    try:
        return "/" + proc.environ().get("ROS_NAMESPACE", "").strip("/")
    except psutil.Error:
        return None


def ros_graph(env: Mapping[str, str], ros: int, cmdline: Sequence[str] = ()) -> str:
    """The ROS graph of a process with this environment and command line: its master (ROS
    1: ``__master:=``, else ROS_MASTER_URI; every name of this machine counts as one) or its
    domain (ROS 2: ROS_DOMAIN_ID).  Two graphs on one machine may have nodes of one name."""
    if ros == 2:
        return f"domain {env.get('ROS_DOMAIN_ID') or '0'}"
    masters = [a.partition(":=")[2] for a in cmdline if a.startswith("__master:=")]
    uri = masters[-1] if masters else env.get("ROS_MASTER_URI") or "http://localhost:11311"
    address = host_port(uri)
    if address is None:
        return f"master {uri}"
    host, port = address
    local = host in ("localhost", "::1", socket.gethostname()) or host.startswith("127.")
    return f"master {'this machine' if local else host}:{port}"


def in_graph(proc: psutil.Process, ros: int, graph: str | None, cmdline: Sequence[str]) -> bool:
    """The process is of the ROS graph ``graph`` (:func:`ros_graph`; None: any), or its
    environment cannot be read (then it may be)."""
    if graph is None:
        return True
    try:
        env = proc.environ()
    except psutil.Error:
        return True
    return ros_graph(env, ros, cmdline) == graph


def ros1_named(node: str, unreadable: bool, graph: str | None = None) -> list[psutil.Process]:
    """Live processes whose command line names the ROS 1 node ``ns/name`` (``__name:=``)
    in its namespace (and its ROS graph, :func:`ros_graph`); ``unreadable``: and those whose
    namespace cannot be read."""
    ns, _, base = node.strip("/").rpartition("/")
    wanted = "/" + ns
    out = []
    for proc in psutil.process_iter(["cmdline", "status"]):
        line = proc.info["cmdline"] or []
        if f"__name:={base}" not in line or proc.info["status"] == psutil.STATUS_ZOMBIE:
            continue
        if not in_graph(proc, 1, graph, line):
            continue
        space = _namespace(proc, line)
        if (space is None and unreadable) or (
            space is not None and space.rstrip("/") == wanted.rstrip("/")
        ):
            out.append(proc)
    return out


def _parents(proc: psutil.Process) -> set[int]:
    try:
        return {p.pid for p in proc.parents()}
    except psutil.Error:
        return set()


def prove_by_cmdline(pid: int) -> Found:
    """A process found by the ``__node:=`` on its command line (ROS 2), trusted when it is
    of this PID namespace and this host."""
    if not in_own_pid_namespace(pid):
        why = f"its process {pid} is in another PID namespace (a container): not watched"
        return Found(None, why)
    if not on_this_host(pid):
        return Found(None, f"its process {pid} is in another network namespace: not watched")
    return Found(pid, f"pid {pid}'s command line names it")


# -- what the observer host does with a node's placement ------------------------------------


class PlacementView:
    """The atoms of each node's NObs and PObs, and what a change of placement means for
    them: a node watched through the middleware alone has no cpu or memory samples, so
    its property atoms become unknown (their last verdict is withdrawn, not kept as
    ``ok``), and its ``running`` row says ``watched: middleware``."""

    def __init__(self, specs: Iterable[ObserverSpec]) -> None:
        self.running: dict[str, Atom] = {}
        self.properties: dict[str, list[Atom]] = {}
        for spec in specs:
            params = dict(spec.params)
            node = str(params.get("node", "")).strip().lstrip("/")
            if spec.kind == "NObs" and spec.atoms:
                self.running[node] = spec.atoms[0]
            elif spec.kind == "PObs":
                self.properties.setdefault(node, []).extend(spec.atoms)

    def values(self, node: str, found: Found) -> tuple[tuple[str, str], ...]:
        return (("watched", found.watched), ("how", found.how))

    def line(self, t: float, node: str, found: Found) -> str:
        """A greppable log line: ``t=… watch talker: middleware (why)``."""
        return f"t={t:.3f} watch {node}: {found.watched} ({found.how})"

    def atoms(self, node: str) -> list[Atom]:
        running = self.running.get(node)
        return [*([running] if running is not None else []), *self.properties.get(node, ())]

    def withdrawn(self, node: str, found: Found) -> list[Atom]:
        """The atoms that become unknown when ``node`` is watched as ``found`` says: its
        properties without a proven process, its ``running`` too when that is unknown."""
        if found.unknown:
            return self.atoms(node)
        return [] if found.pid is not None else list(self.properties.get(node, ()))

    def measurable(self, node: str, found: Found) -> list[Atom]:
        """The atoms of ``node`` that are judged again when it is watched as ``found`` says."""
        gone = set(self.withdrawn(node, found))
        return [a for a in self.atoms(node) if a not in gone]
