"""``racc run``'s side of a launch file: the arguments it takes, and the processes of the
nodes it names, started, watched and stopped without ``roslaunch`` or ``ros2 launch``.

Which command line each node gets is the transport's business (:mod:`rac.ros1.run`,
:mod:`rac.ros2.run`); this module holds what both share: reading ``<arg>`` declarations,
checking ``NAME:=VALUE`` against them, and a :class:`Supervisor` that starts every process
in its own session, prefixes its output with the node's name, and stops them all with
SIGINT (then SIGTERM, then SIGKILL) when asked to, or when one of them fails.
"""

from __future__ import annotations

import difflib
import os
import signal
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from rac.errors import Diagnostic, RacError

STOP_GRACE_S = 10.0  # what each node gets to end on SIGINT before SIGTERM
# A node that respawns is given up on (and racc run stops) when it ended this many times
# within the window, as systemd's StartLimitBurst/StartLimitIntervalSec: a crash loop does
# not watch the robot, it only hides that nothing does.
RESPAWN_BURST = 5
RESPAWN_WINDOW_S = 60.0
MIN_RESPAWN_DELAY_S = 1.0
# A racc node's exit codes that say its input is wrong (1) or its command line (2): a new
# start would end the same way, so racc run stops instead of respawning it.
INPUT_WRONG = (1, 2)
# racc's own runtime nodes: launch file executable -> racc command
RACC_EXECUTABLES = {
    "observe": "observe",
    "engine": "engine",
    "repairer": "repairer",
    "board_client": "board-client",
}
# A racc node is run by this Python through the transport's entry point, as the executables
# of the racc ROS packages run it: no package needs to be installed for ``racc run``.
# Ctrl-C while it starts (importing takes seconds on a loaded machine) is a clean end too.
ENTRY = (
    "import sys\n"
    "try:\n"
    "    from rac.entry_ros{ros} import main\n"
    "except KeyboardInterrupt:\n"
    "    sys.exit(0)\n"
    "sys.exit(main(sys.argv[1], sys.argv[2:]))\n"
)


@dataclass(frozen=True, slots=True)
class LaunchArg:
    """An ``<arg name=… default=…/>`` of a launch file (``value=``: fixed, not settable)."""

    name: str
    default: str | None  # None: the file gives none, the argument must be set
    settable: bool
    doc: str


@dataclass(frozen=True, slots=True)
class NodeProcess:
    """One node to run: its name (for the output prefix) and its command line; ``respawn``:
    started again when it ends, after ``respawn_delay`` s (roslaunch's and ros2 launch's
    attributes of the same names)."""

    name: str
    command: tuple[str, ...]
    env: tuple[tuple[str, str], ...] = ()
    respawn: bool = False
    respawn_delay: float = 0.0


def racc_command(ros: int, executable: str) -> list[str] | None:
    """The command line start of racc's node ``executable``, or None if it is not one."""
    command = RACC_EXECUTABLES.get(executable)
    if command is None:
        return None
    return [sys.executable, "-c", ENTRY.format(ros=ros), command]


def launch_arguments(path: Path) -> list[LaunchArg]:
    """The ``<arg>`` declarations of a ROS 1 or ROS 2 launch XML file, in file order."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as err:
        why = f"{path}: cannot read the launch file: {err}"
        raise RacError([Diagnostic("RAC130", why)]) from None
    found: list[LaunchArg] = []
    for e in root.iter("arg"):
        name = e.get("name", "")
        if name:
            fixed = "value" in e.attrib
            default = e.get("value") if fixed else e.get("default")
            found.append(LaunchArg(name, default, not fixed, e.get("doc", "")))
    return found


def parse_assignments(
    path: Path, declared: Sequence[LaunchArg], given: Sequence[str]
) -> dict[str, str]:
    """``NAME:=VALUE`` words checked against the file's arguments (RAC130 otherwise)."""
    names = {a.name for a in declared if a.settable}
    values: dict[str, str] = {}
    for word in given:
        name, sep, value = word.partition(":=")
        if not sep or not name:
            raise RacError(
                [
                    Diagnostic(
                        "RAC130",
                        f"'{word}' is not an argument assignment",
                        hint=f"write NAME:=VALUE; {path.name} takes {_listing(declared)}",
                    )
                ]
            )
        if name not in names:
            close = difflib.get_close_matches(name, sorted(names), n=1)
            hint = f"did you mean '{close[0]}'? " if close else ""
            raise RacError(
                [
                    Diagnostic(
                        "RAC130",
                        f"{path.name} takes no argument '{name}'",
                        hint=f"{hint}it takes {_listing(declared)}",
                    )
                ]
            )
        values[name] = value
    missing = [a.name for a in declared if a.settable and a.default is None]
    missing = [m for m in missing if m not in values]
    if missing:
        raise RacError(
            [
                Diagnostic(
                    "RAC130",
                    f"{path.name} needs a value for {', '.join(missing)}",
                    hint="give " + " ".join(f"{m}:=VALUE" for m in missing),
                )
            ]
        )
    return values


def _listing(declared: Sequence[LaunchArg]) -> str:
    settable = [a.name for a in declared if a.settable]
    return ", ".join(settable) if settable else "no arguments"


def describe_arguments(declared: Sequence[LaunchArg]) -> list[str]:
    """``NAME:=DEFAULT`` lines for ``racc run --args``."""
    lines = []
    for a in declared:
        if not a.settable:
            continue
        default = "(required)" if a.default is None else a.default or "''"
        lines.append(f"  {a.name}:={default}" + (f"    {a.doc}" if a.doc else ""))
    return lines


class Supervisor:
    """Runs node processes until asked to stop or until one fails; then stops them all.

    A node that ends by itself is started again when it respawns (``respawn``), after its
    delay (at least :data:`MIN_RESPAWN_DELAY_S`), and its loss and return are said; unless
    it ended because its input is wrong (:data:`INPUT_WRONG`) or ended
    :data:`RESPAWN_BURST` times within :data:`RESPAWN_WINDOW_S`: then every node is stopped
    and racc run exits 1.  A node that does not respawn stops the others when it ends."""

    def __init__(self, out: IO[str] | None = None, quiet: bool = False) -> None:
        self.out = out or sys.stdout
        self.quiet = quiet
        self.procs: list[tuple[NodeProcess, subprocess.Popen[bytes]]] = []
        self._pumps: list[threading.Thread] = []
        self._lock = threading.Lock()
        self.stop_requested = threading.Event()
        self._env: dict[str, Mapping[str, str]] = {}
        self._ended: dict[str, list[float]] = {}  # node -> when it ended lately
        self._due: dict[int, float] = {}  # index in procs -> when it starts again

    def say(self, text: str) -> None:
        with self._lock:
            print(f"t={time.time():.3f} racc run: {text}", file=self.out, flush=True)

    def start(self, node: NodeProcess, base_env: Mapping[str, str]) -> None:
        self._env[node.name] = base_env
        self.procs.append((node, self._spawn(node)))
        self.say(f"started {node.name} (pid {self.procs[-1][1].pid})")

    def _spawn(self, node: NodeProcess) -> subprocess.Popen[bytes]:
        env = {**self._env[node.name], **dict(node.env), "PYTHONUNBUFFERED": "1"}
        proc = subprocess.Popen(
            list(node.command),
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL if self.quiet else subprocess.PIPE,
            stderr=subprocess.STDOUT,
            # Its own session: Ctrl-C reaches racc run alone, which stops each node once.
            start_new_session=True,
        )
        if proc.stdout is not None:
            pump = threading.Thread(target=self._pump, args=(node.name, proc.stdout), daemon=True)
            pump.start()
            self._pumps.append(pump)
        return proc

    def _pump(self, name: str, stream: IO[bytes]) -> None:
        for raw in iter(stream.readline, b""):
            line = raw.decode("utf-8", "replace").rstrip()
            with self._lock:
                print(f"[{name}] {line}", file=self.out, flush=True)

    def wait(self, duration: float | None = None) -> int:
        """Until a stop is requested, ``duration`` passes or a node ends for good; 0, or 1
        when a node ended for good (every other one is stopped then)."""
        end = None if duration is None else time.time() + duration
        while not self.stop_requested.is_set() and (end is None or time.time() < end):
            now = time.monotonic()
            for i, (node, proc) in enumerate(self.procs):
                if i in self._due:
                    if now >= self._due[i]:
                        del self._due[i]
                        self.procs[i] = (node, self._spawn(node))
                        self.say(f"restarted {node.name} (pid {self.procs[i][1].pid})")
                    continue
                code = proc.poll()
                if code is not None and self._ended_for_good(i, node, code, now):
                    return 1
            self.stop_requested.wait(0.2)
        return 0

    def _ended_for_good(self, i: int, node: NodeProcess, code: int, now: float) -> bool:
        how = ended_how(code)
        if not node.respawn or code in INPUT_WRONG:
            self.say(f"{node.name} ended by itself ({how}); stopping the others")
            return True
        ended = [t for t in self._ended.get(node.name, []) if now - t < RESPAWN_WINDOW_S]
        ended.append(now)
        self._ended[node.name] = ended
        if len(ended) >= RESPAWN_BURST:
            self.say(
                f"{node.name} ended {len(ended)} times within {RESPAWN_WINDOW_S:g} s ({how} "
                "the last time): not restarting it again; stopping the others"
            )
            return True
        delay = max(node.respawn_delay, MIN_RESPAWN_DELAY_S)
        self.say(
            f"{node.name} ended by itself ({how}): racc lacks it until it is back; restarting "
            f"it in {delay:g} s ({len(ended)} of {RESPAWN_BURST} ends allowed in "
            f"{RESPAWN_WINDOW_S:g} s)"
        )
        self._due[i] = now + delay
        return False

    def stop(self) -> None:
        """SIGINT to every node still running, then SIGTERM, then SIGKILL, each after
        :data:`STOP_GRACE_S` (what roslaunch does)."""
        self._due.clear()
        running = [(n, p) for n, p in self.procs if p.poll() is None]
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            for _, proc in running:
                if proc.poll() is None:
                    _signal_group(proc, sig)
            deadline = time.time() + STOP_GRACE_S
            while time.time() < deadline and any(p.poll() is None for _, p in running):
                time.sleep(0.05)
            if all(p.poll() is not None for _, p in running):
                break
            names = ", ".join(n.name for n, p in running if p.poll() is None)
            self.say(f"{names} did not end on {signal.Signals(sig).name}")
        for pump in self._pumps:
            pump.join(2.0)
        if running:
            codes = ", ".join(f"{n.name} {p.returncode}" for n, p in running)
            self.say(f"stopped {len(running)} nodes (exit codes: {codes})")


def ended_how(code: int) -> str:
    """``exit code 1`` or ``killed by SIGKILL`` (a Popen's negative return code)."""
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def _signal_group(proc: subprocess.Popen[bytes], sig: int) -> None:
    """SIGINT and SIGTERM to the node alone (the repair engine stops the robot nodes it
    restarted itself); SIGKILL to its whole session, so that nothing it started outlives it."""
    try:
        if sig == signal.SIGKILL:
            os.killpg(proc.pid, sig)
        else:
            proc.send_signal(sig)
    except (ProcessLookupError, PermissionError):
        pass


def stop_on_signals(supervisor: Supervisor) -> None:
    """SIGINT and SIGTERM ask the supervisor to stop (no KeyboardInterrupt)."""

    def handler(signum: int, frame: object) -> None:
        supervisor.stop_requested.set()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
