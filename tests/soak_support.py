"""What the live tests (tests/live_harness.py, tests/ros1/test_real_graph.py) and
``bench/soak.py`` share, for either ROS version.

- ``Watch``: racc's runtime topics (/observations, /diagnosis, /repair_log) as a separate
  monitor process sees them (``python tests/soak_support.py ros1|ros2``), time-stamped with
  this machine's clock.  A process of its own, so that a test module needs no rospy/rclpy
  node of its own (rospy allows one per process), and the same code serves both versions.
- ``Processes``: everything a test starts, each in a process group of its own, stopped by
  pid and process group, never by name (other runs share the machine): SIGINT first, so
  that roslaunch ends its children, then SIGKILL of the group.
- ``cpu_load``: Debian's stress-ng on every core at a given load, stopped by its group.
- ``episodes``, ``plans``, ``named_since``, ``all_ok_since``: the figures of the issue
  (false diagnosis episodes, repair plans, detection and recovery times).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

ROOT = Path(__file__).resolve().parents[1]
RACC = [sys.executable, "-m", "rac"]

# A repair log entry: time seen, action, target, level, message.
LogRow = tuple[float, str, str, int, str]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass
class Watch:
    """The runtime's topics, read from a monitor process's JSON lines."""

    observations: list[tuple[float, list[tuple[str, int]]]] = field(default_factory=list)
    seen: dict[str, tuple[str, int]] = field(default_factory=dict)  # atom -> (literal, level)
    diagnosis: list[tuple[float, list[str]]] = field(default_factory=list)
    repair_log: list[LogRow] = field(default_factory=list)
    nodes: set[str] = field(default_factory=set)  # the graph's node names, once a second
    # The repair engine's status on /diagnostics: (time, level, message, values).
    repairer: list[tuple[float, int, str, dict[str, str]]] = field(default_factory=list)
    # racc's other statuses on /diagnostics (what each node ignored, whether a host is
    # blind): (time, name, level, message).
    statuses: list[tuple[float, str, int, str]] = field(default_factory=list)
    # Reentrant: a condition given to wait() (which holds it) may read through since().
    lock: threading.RLock = field(default_factory=threading.RLock)
    ready: threading.Event = field(default_factory=threading.Event)

    def feed(self, stream: IO[bytes]) -> None:
        for raw in stream:
            try:
                line = json.loads(raw)
            except ValueError:
                continue
            with self.lock:
                t, kind = line["t"], line["kind"]
                if kind == "ready":
                    self.ready.set()
                elif kind == "observations":
                    # An array holds the rows that changed, or all of them: merged, so
                    # that each entry is the whole observation set as it stood then.
                    self.seen.update({name: (m, lv) for name, m, lv in line["rows"]})
                    self.observations.append((t, list(self.seen.values())))
                elif kind == "diagnosis":
                    self.diagnosis.append((t, list(line["rows"])))
                elif kind == "nodes":
                    self.nodes = set(line["rows"])
                elif kind == "repairer":
                    for lv, msg, values in line["rows"]:
                        self.repairer.append((t, lv, msg, dict(values)))
                elif kind == "status":
                    for name, lv, msg in line["rows"]:
                        self.statuses.append((t, name, lv, msg))
                elif kind == "repair_log":
                    for name, hw, lv, msg in line["rows"]:
                        self.repair_log.append((t, name, hw, lv, msg))

    def wait(self, what: Callable[[], float | None], timeout: float) -> float | None:
        deadline = time.time() + timeout
        while True:
            with self.lock:
                found = what()
            if found is not None or time.time() >= deadline:
                return found
            time.sleep(0.1)

    def since(self, after: float) -> list[LogRow]:
        with self.lock:
            return [row for row in self.repair_log if row[0] >= after]


class Processes:
    """Everything started here, each process the leader of its own group."""

    def __init__(self, env: dict[str, str], logs: Path) -> None:
        self.env = env
        self.logs = logs
        self.procs: list[subprocess.Popen[bytes]] = []

    def start(
        self, args: list[str], log: str, stdout: int | None = None
    ) -> subprocess.Popen[bytes]:
        out = open(self.logs / log, "ab")  # noqa: SIM115 - closed with the process
        proc = subprocess.Popen(
            args,
            env=self.env,
            stdout=out if stdout is None else stdout,
            stderr=out,
            start_new_session=True,
        )
        self.procs.append(proc)
        return proc

    def stop(self, proc: subprocess.Popen[bytes], grace: float = 20.0) -> None:
        """SIGINT (roslaunch then stops its nodes), SIGKILL after ``grace``; then whatever
        is left of its process group."""
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(grace)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5)
        kill_group(proc.pid)

    def stop_all(self) -> None:
        for proc in reversed(self.procs):
            self.stop(proc)
        self.procs.clear()


def kill_group(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGCONT)  # a SIGSTOPped member would never end otherwise
        os.killpg(pgid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def kill_pid(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGCONT)
        os.kill(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def start_watch(procs: Processes, ros: str) -> Watch:
    """The monitor process on the runtime's topics; waits until it is subscribed."""
    watch = Watch()
    proc = procs.start(
        [sys.executable, "-u", str(Path(__file__)), ros], f"monitor_{ros}.log", subprocess.PIPE
    )
    assert proc.stdout is not None
    threading.Thread(target=watch.feed, args=(proc.stdout,), daemon=True).start()
    assert watch.ready.wait(30), "the monitor node did not start"
    return watch


def compile_model(model: Path, build: Path, env: dict[str, str]) -> int:
    """``racc compile``; the number of atoms the observers report."""
    from rac.load.files import load_observers

    subprocess.run(
        [*RACC, "compile", str(model), "-o", str(build), "--no-svg", "-q"],
        check=True,
        env=env,
        timeout=120,
    )
    return sum(len(s.atoms) for s in load_observers(build / "observers.yaml")[1])


def racc_learn(recording: Path, stem: Path, learned: Path, env: dict[str, str]) -> Path:
    """``racc learn`` of what ``racc record -o STEM`` wrote (the recording, STEM.graph.yaml,
    STEM.properties.csv): the model ``learned``, as a user would learn it."""
    subprocess.run(
        [
            *RACC,
            "learn",
            str(recording),
            "--graph",
            f"{stem}.graph.yaml",
            "--properties",
            f"{stem}.properties.csv",
            "-o",
            str(learned),
            "-q",
        ],
        check=True,
        env=env,
        timeout=600,
    )
    return learned


@contextmanager
def cpu_load(procs: Processes, percent: int, cpus: int = 2) -> Iterator[None]:
    """stress-ng's cpu workers, one per core, each busy ``percent`` of the time."""
    if percent <= 0:
        yield
        return
    proc = procs.start(
        ["stress-ng", "--cpu", str(cpus), "--cpu-load", str(percent), "--quiet"], "stress.log"
    )
    try:
        yield
    finally:
        procs.stop(proc, grace=5)
        procs.procs.remove(proc)


# -- the figures --------------------------------------------------------------------------


def episodes(watch: Watch, start: float, end: float) -> list[tuple[float, list[str]]]:
    """Diagnosis episodes in [start, end): each time /diagnosis turned from no fault to a
    non-empty diagnosis, and the one under way at ``start`` if there is one (on a healthy
    robot a diagnosis that never clears is a false alarm too)."""
    found: list[tuple[float, list[str]]] = []
    with watch.lock:
        before = [d for t, d in watch.diagnosis if t < start]
        if before and before[-1]:
            found.append((start, before[-1]))
        faulty = bool(before and before[-1])
        for t, d in watch.diagnosis:
            if not start <= t < end:
                continue
            if d and not faulty:
                found.append((t, d))
            faulty = bool(d)
    return found


def plans(watch: Watch, start: float, end: float) -> list[LogRow]:
    """Repair plans and node or device actions logged in [start, end)."""
    acting = {"plan", "stop_node", "start_node", "shutdown", "power_up"}
    with watch.lock:
        return [r for r in watch.repair_log if start <= r[0] < end and r[1] in acting]


@dataclass
class Soak:
    """What a healthy soak under load came to (:func:`soak_under_load`)."""

    start: float
    end: float
    acted: list[LogRow]  # plans and actions from ``acted_since``
    episodes: list[tuple[float, list[str]]]


def soak_under_load(
    procs: Processes, watch: Watch, load: int, seconds: float, name: str, acted_since: float
) -> Soak:
    """``seconds`` of stress-ng at ``load`` % on both cores with nothing wrong; the plans
    made since ``acted_since`` (bring-up included when it is the launch) and the diagnosis
    episodes of the soak, printed (``-s``) under ``name``."""
    with cpu_load(procs, load):
        start = time.time()
        time.sleep(seconds)
        end = time.time()
    soak = Soak(start, end, plans(watch, acted_since, end), episodes(watch, start, end))
    shown = [(round(t - start, 1), d) for t, d in soak.episodes]
    print(f"\n{name}: soak {seconds:g} s at {load} % load on both cores")
    print(f"  repair: {shown_plans(soak.acted, acted_since)}")
    print(f"  diagnosis episodes: {len(soak.episodes)} {shown}")
    print(f"  observations turned negative: {flips(watch, start, end)}")
    return soak


def named_since(watch: Watch, after: float, component: str) -> Callable[[], float | None]:
    """First time after ``after`` that a diagnosis names ``component``."""

    def check() -> float | None:
        for t, diagnoses in watch.diagnosis:
            if t >= after and any(component in d.split(",") for d in diagnoses):
                return t
        return None

    return check


def all_ok_since(watch: Watch, after: float, atoms: int) -> Callable[[], float | None]:
    """When every observation was ok (``atoms`` of them) and /diagnosis empty, after
    ``after``."""

    def check() -> float | None:
        ok = [
            t
            for t, rows in watch.observations
            if t >= after and len(rows) >= atoms and all(level == 0 for _, level in rows)
        ]
        if not ok:
            return None
        empty = [t for t, d in watch.diagnosis if t >= ok[0] and not d]
        return max(ok[0], empty[0]) if empty else None

    return check


def logged_done(watch: Watch, after: float, action: str, target: str) -> float | None:
    for t, name, hw, _, msg in watch.since(after):
        if name == action and hw == target and msg.startswith("done"):
            return t
    return None


# -- the monitor process --------------------------------------------------------------------


def _emit(kind: str, rows: list[Any]) -> None:
    sys.stdout.write(json.dumps({"t": time.time(), "kind": kind, "rows": rows}) + "\n")
    sys.stdout.flush()


def _level(status: Any) -> int:
    level = status.level
    return level[0] if isinstance(level, bytes) else int(level)


def _callbacks() -> dict[str, Callable[[Any], None]]:
    def obs(a: Any) -> None:
        _emit("observations", [(s.name, s.message, _level(s)) for s in a.status])

    def diag(a: Any) -> None:
        _emit("diagnosis", [s.message for s in a.status])

    def log(a: Any) -> None:
        _emit("repair_log", [(s.name, s.hardware_id, _level(s), s.message) for s in a.status])

    def status(a: Any) -> None:
        rows = [
            (_level(s), s.message, [(kv.key, kv.value) for kv in s.values])
            for s in a.status
            if s.name.endswith(": repair")
        ]
        if rows:
            _emit("repairer", rows)
        others = [
            (s.name, _level(s), s.message)
            for s in a.status
            if s.name.startswith("racc_") and not s.name.endswith(": repair")
        ]
        if others:
            _emit("status", others)

    return {"/observations": obs, "/diagnosis": diag, "/repair_log": log, "/diagnostics": status}


def _graph_nodes_ros1() -> list[str]:
    import rosgraph

    try:
        state = rosgraph.Master("/racc_soak_monitor").getSystemState()
    except Exception:  # the master is going away
        return []
    return sorted({n.lstrip("/") for group in state for _, nodes in group for n in nodes})


def _monitor_ros1() -> None:
    import rospy
    from diagnostic_msgs.msg import DiagnosticArray

    rospy.init_node("racc_soak_monitor", anonymous=True)
    for topic, callback in _callbacks().items():
        rospy.Subscriber(topic, DiagnosticArray, callback, queue_size=100)
    rospy.Timer(rospy.Duration(1.0), lambda _event: _emit("nodes", _graph_nodes_ros1()))
    _emit("ready", [])
    rospy.spin()


def _monitor_ros2() -> None:
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray

    from rac.ros2.common import reliable

    rclpy.init()
    node = rclpy.create_node(f"racc_soak_monitor_{os.getpid()}")
    for topic, callback in _callbacks().items():
        # /diagnostics is not latched: a transient-local subscription would not match it.
        latched = topic != "/diagnostics"
        node.create_subscription(DiagnosticArray, topic, callback, reliable(50, latched))
    node.create_timer(1.0, lambda: _emit("nodes", sorted(node.get_node_names())))
    _emit("ready", [])
    with suppress(KeyboardInterrupt):
        rclpy.spin(node)


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    {"ros1": _monitor_ros1, "ros2": _monitor_ros2}[sys.argv[1]]()


def flips(watch: Watch, start: float, end: float) -> dict[str, int]:
    """Per literal, how often it turned negative in [start, end) (what cried wolf)."""
    counts: dict[str, int] = {}
    last: dict[str, int] = {}
    with watch.lock:
        for t, rows in watch.observations:
            for message, level in rows:
                atom = message.removeprefix("not_")
                if t >= start and t < end and level and not last.get(atom, 0):
                    counts[message] = counts.get(message, 0) + 1
                last[atom] = level
    return counts


def timeline(watch: Watch, start: float, end: float) -> str:
    """Every change of an observation's level (but a first ok) and of /diagnosis in
    [start, end), one per line with its time from ``start``: what explains a plan."""
    lines: list[str] = []
    last: dict[str, int] = {}
    with watch.lock:
        events: list[tuple[float, int, list[Any]]] = [
            (t, 0, rows) for t, rows in watch.observations
        ]
        events += [(t, 1, d) for t, d in watch.diagnosis]
        previous: object = None
        for t, kind, rows in sorted(events, key=lambda e: (e[0], e[1])):
            if not start <= t < end:
                continue
            if kind == 1:
                if rows != previous:
                    lines.append(f"    {t - start:6.2f} s  diagnosis {rows or 'empty'}")
                previous = rows
                continue
            for message, level in rows:
                atom = message.removeprefix("not_")
                if last.get(atom, 0) != level:  # a first ok is no news
                    lines.append(f"    {t - start:6.2f} s  {message} level {level}")
                last[atom] = level
    return "\n".join(lines)


def shown_plans(acted: list[LogRow], since: float) -> str:
    """The plans among ``acted``, one per line, with their time from ``since``."""
    lines = [f"    {t - since:6.1f} s  {msg}" for t, name, _, _, msg in acted if name == "plan"]
    return f"{len(lines)} plans, {len(acted)} actions" + "".join("\n" + x for x in lines)


def faulty_share(watch: Watch, start: float, end: float) -> float:
    """The share of [start, end) during which /diagnosis named a fault."""
    with watch.lock:
        before = [d for t, d in watch.diagnosis if t < start]
        faulty, since, total = bool(before and before[-1]), start, 0.0
        for t, d in watch.diagnosis:
            if not start <= t < end:
                continue
            if faulty:
                total += t - since
            faulty, since = bool(d), t
        if faulty:
            total += end - since
    return total / (end - start) if end > start else 0.0
