"""What bounds the life of a node racc starts (issue 34): racc's side of the guardian.

:mod:`rac.runtime.guardian` is the process that starts a node and stops it when the robot
stops.  Here racc finds what the guardian watches, when it starts a node: the robot's
launch process (:func:`launch_process`), the ROS 1 master, or the robot's other ROS 2 nodes
(:class:`Lifetime`), and starts the guardian (:func:`start_guarded`), which answers the
node's own pid: that is the pid racc logs, signals and watches.
"""

from __future__ import annotations

import itertools
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import psutil

from rac.errors import Diagnostic, RacError
from rac.runtime import guardian
from rac.runtime.guardian import DEFAULT_GONE_S, Orders, process_start

ANSWER_S = 15.0  # for the guardian to start the node and answer its pid (a loaded machine)


@dataclass(frozen=True, slots=True)
class LaunchProcess:
    """The robot's launch process: its pid, its start (against pid reuse), what it is."""

    pid: int
    start: int
    what: str  # "roslaunch of /path/robot.launch"


@dataclass(frozen=True, slots=True)
class Lifetime:
    """When the robot counts as stopped, for the guardian of one node."""

    launch: LaunchProcess | None = None
    master_uri: str | None = None  # ROS 1: the robot's master
    others: tuple[str, ...] = ()  # ROS 2: the robot's other nodes
    gone_s: float = DEFAULT_GONE_S

    def orders(
        self,
        node: str,
        argv: Sequence[str],
        env: Mapping[str, str],
        log: Path,
        cwd: str | None,
    ) -> Orders:
        launch = self.launch
        return Orders(
            argv=tuple(argv),
            env=dict(env),
            log=str(log),
            node=node,
            cwd=cwd,
            launch_pid=launch.pid if launch else None,
            launch_start=launch.start if launch else None,
            launch_what=launch.what if launch else "",
            master_uri=self.master_uri,
            others=tuple(o for o in self.others if o.strip("/") != node.strip("/")),
            others_from_start=launch is None,
            gone_s=self.gone_s,
        )

    def describe(self) -> str:
        """What stops a node started with this lifetime, for the start_node line."""
        out = []
        if self.launch is not None:
            out.append(f"{self.launch.what} (pid {self.launch.pid}) ends")
        if self.master_uri is not None:
            out.append(f"the master has been gone {self.gone_s:g} s")
        if self.others:
            out.append(f"the robot's other local nodes have been gone {self.gone_s:g} s")
        return " or ".join(out) if out else "it exits (no launch process or master known)"


# -- the robot's launch process -----------------------------------------------------------------


LAUNCHERS = frozenset({"roslaunch", "ros2", "launch", "racc", "python", "python3"})


def _launcher(cmdline: Sequence[str]) -> str | None:
    """What kind of launcher the command line is: "roslaunch", "ros2 launch", "racc demo"."""
    names = [os.path.basename(a) for a in cmdline[:3]]
    if "roslaunch" in names:
        return "roslaunch"
    for a, b in itertools.pairwise(cmdline):
        if os.path.basename(a) == "ros2" and b == "launch":
            return "ros2 launch"
    racc = "racc" in names or any(a == "-m" and b == "rac" for a, b in itertools.pairwise(cmdline))
    if racc and "demo" in cmdline:
        return "racc demo"
    return None


def _demo_output(cmdline: Sequence[str]) -> str | None:
    """The ``-o``/``--output`` folder of a ``racc demo`` command line."""
    for i, a in enumerate(cmdline):
        if a in ("-o", "--output") and i + 1 < len(cmdline):
            return cmdline[i + 1]
        if a.startswith("--output="):
            return a.partition("=")[2]
        if a.startswith("-o") and len(a) > 2:
            return a[2:]
    return None


def _resolved(path: str, cwd: str | None) -> str:
    return os.path.realpath(os.path.join(cwd or "/", os.path.expanduser(path)))


def _holds_launch(proc: psutil.Process, kind: str, cmdline: Sequence[str], target: str) -> int:
    """How surely the process runs the launch file ``target``: 2 its command line names the
    file (a path, resolved against its working directory), 1 its name only, after a package
    (``roslaunch PKG FILE``, ``ros2 launch PKG FILE``: the file is the package's, wherever
    the process runs), 0 not at all."""
    name = os.path.basename(target)
    args = list(cmdline)
    if kind == "racc demo":
        out = _demo_output(args)
        if out is None or name not in ("robot.launch", "robot.launch.xml"):
            return 0
        return 2 if _resolved(os.path.join(out, name), _cwd(proc)) == target else 0
    named = [i for i, a in enumerate(args) if os.path.basename(a) == name]
    if not named:
        return 0
    paths = [args[i] for i in named if not _after_package(args, i)]
    if paths and any(_resolved(a, _cwd(proc)) == target for a in paths):
        return 2
    return 1 if len(paths) < len(named) else 0


def _after_package(args: Sequence[str], i: int) -> bool:
    """Whether ``args[i]``, a bare file name, follows a package name (``PKG FILE``)."""
    if i == 0 or "/" in args[i]:
        return False
    before = args[i - 1]
    return (
        bool(before)
        and not before.startswith("-")
        and (
            "/" not in before
            and os.path.basename(before) not in LAUNCHERS
            and not before.endswith((".launch", ".xml", ".py", ".yaml"))
        )
    )


def _cwd(proc: psutil.Process) -> str | None:
    try:
        return str(proc.cwd())
    except psutil.Error:
        return None


def launch_process(launch_file: str | None) -> LaunchProcess | None:
    """The process that runs the robot's launch file on this machine: ``roslaunch FILE``,
    ``ros2 launch FILE`` or ``racc demo -o DIR`` (whose robot.launch it wrote and runs);
    ``roslaunch PKG FILE`` by the file's name when no process names its path.  Of several,
    the outermost (racc demo before the roslaunch it started), then the newest.  None
    without a launch file, or when none runs here (the robot was started otherwise, or on
    another machine)."""
    if not launch_file:
        return None
    target = os.path.realpath(launch_file)
    found: list[tuple[psutil.Process, str, int]] = []
    for proc in psutil.process_iter(["cmdline"]):
        cmdline = proc.info["cmdline"] or []
        if proc.pid == os.getpid():
            continue
        kind = _launcher(cmdline)
        sure = _holds_launch(proc, kind, cmdline, target) if kind is not None else 0
        if kind is not None and sure:
            found.append((proc, kind, sure))
    best = max((sure for _, _, sure in found), default=0)
    found = [f for f in found if f[2] == best]
    pids = {p.pid for p, _, _ in found}
    outer = []
    for proc, kind, _ in found:
        try:
            ancestors = {a.pid for a in proc.parents()}
        except psutil.Error:
            continue
        if not ancestors & (pids - {proc.pid}):
            outer.append((proc, kind))
    for proc, kind in sorted(outer, key=lambda pk: -_created(pk[0])):
        start = process_start(proc.pid)
        if start is not None:
            return LaunchProcess(proc.pid, start, f"{kind} of {target}")
    return None


def _created(proc: psutil.Process) -> float:
    try:
        return float(proc.create_time())
    except psutil.Error:
        return 0.0


# -- starting a node under its guardian ------------------------------------------------------


def guardian_argv() -> list[str]:
    """The guardian as a script of the standard library only: ``-I`` (no user site, no
    PYTHON* variables), ``-S`` (no site packages)."""
    return [sys.executable, "-I", "-S", guardian.__file__]


def start_guarded(orders: Orders) -> tuple[subprocess.Popen[bytes], int]:
    """Start the node of ``orders`` under a guardian in a session of its own: (the guardian,
    the node's pid).  RAC111 when the node cannot be started."""
    node = orders.node or "the node"
    with open(orders.log, "ab") as log:
        proc = subprocess.Popen(
            guardian_argv(),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=log,
            start_new_session=True,
            close_fds=True,
        )
    assert proc.stdin is not None and proc.stdout is not None
    try:
        proc.stdin.write(orders.to_json().encode())
        proc.stdin.close()
    except OSError as err:
        proc.kill()
        raise _cannot_start(node, f"its guardian did not take the orders: {err}") from None
    answer = _read_line(proc, ANSWER_S)
    proc.stdout.close()
    if answer.startswith("pid "):
        return proc, int(answer[4:])
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(5)
    why = answer[6:] if answer.startswith("error ") else f"no answer in {ANSWER_S:g} s"
    raise _cannot_start(node, why)


def _read_line(proc: subprocess.Popen[bytes], timeout_s: float) -> str:
    assert proc.stdout is not None
    deadline = time.monotonic() + timeout_s
    data = b""
    fd = proc.stdout.fileno()
    while not data.endswith(b"\n"):
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            break
        chunk = os.read(fd, 256)
        if not chunk:
            break
        data += chunk
    return data.decode("utf-8", "replace").strip()


def _cannot_start(node: str, why: str) -> RacError:
    return RacError([Diagnostic("RAC111", f"cannot start '{node}': {why}")])


def robot_nodes(names: Iterable[str]) -> tuple[str, ...]:
    """Node names as the guardian matches them ("ns/name"), without duplicates."""
    return tuple(sorted({n.strip("/") for n in names if n.strip("/")}))
