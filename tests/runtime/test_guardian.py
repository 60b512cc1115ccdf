"""The robot's lifetime bounds every node racc starts (rac.runtime.guardian, issue 34): the
guardian stops its node when the robot's launch process ends, when the ROS 1 master has been
gone longer than the bound (not for a short restart), when the robot's other ROS 2 nodes
are all gone; it ends with its node.  Real processes: a launcher, a node, a fake master (a
listening socket on 127.0.0.1), all stopped by pid."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

from rac.runtime.guardian import (
    GUARDIAN_ENV,
    Orders,
    Watch,
    node_pids,
    process_start,
)
from rac.runtime.lifetime import LaunchProcess, Lifetime, launch_process, start_guarded

SLEEP = "import time; time.sleep(120)"
# A node that ignores SIGINT (a driver busy shutting down its device): SIGTERM ends it.
STUBBORN = "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); time.sleep(120)"
FAST = {"poll_s": 0.05, "slow_poll_s": 0.1}  # the guardian's pace in these tests


def _alive(pid: int) -> bool:
    return process_start(pid) is not None


def _wait(what: Callable[[], bool], timeout: float) -> float | None:
    """Seconds until ``what()`` held (None: not within ``timeout``)."""
    began = time.monotonic()
    while time.monotonic() - began < timeout:
        if what():
            return time.monotonic() - began
        time.sleep(0.02)
    return None


class Started:
    """Processes a test started, killed by pid at the end."""

    def __init__(self) -> None:
        self.pids: list[int] = []
        self.procs: list[subprocess.Popen[bytes]] = []

    def sleeper(self, *args: str, env: dict[str, str] | None = None) -> subprocess.Popen[bytes]:
        proc = subprocess.Popen([sys.executable, "-c", SLEEP, *args], env=env)
        self.procs.append(proc)
        return proc

    def guard(
        self, log: Path, lifetime: Lifetime, code: str = SLEEP, **pace: float
    ) -> tuple[subprocess.Popen[bytes], int]:
        argv = [sys.executable, "-c", code]
        orders = lifetime.orders("talker", argv, dict(os.environ), log, None)
        guardian, pid = start_guarded(_with(orders, **{**FAST, **pace}))
        self.procs.append(guardian)
        self.pids.append(pid)
        return guardian, pid

    def close(self) -> None:
        for pid in self.pids:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
        for proc in self.procs:
            if proc.poll() is None:
                proc.kill()
            proc.wait(10)


@pytest.fixture
def started() -> Iterator[Started]:
    s = Started()
    try:
        yield s
    finally:
        s.close()


def _launch(proc: subprocess.Popen[bytes]) -> LaunchProcess:
    start = process_start(proc.pid)
    assert start is not None
    return LaunchProcess(proc.pid, start, "a test launcher")


class FakeMaster:
    """A listening socket on a free port of 127.0.0.1, closed and opened again at will."""

    def __init__(self) -> None:
        self.sock: socket.socket | None = None
        probe = socket.socket()
        probe.bind(("127.0.0.1", 0))
        self.port = int(probe.getsockname()[1])
        probe.close()
        self.open()

    @property
    def uri(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    def open(self) -> None:
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(("127.0.0.1", self.port))
        sock.listen(16)
        self.sock = sock

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None


@pytest.fixture
def master() -> Iterator[FakeMaster]:
    m = FakeMaster()
    try:
        yield m
    finally:
        m.close()


def test_the_node_stops_when_the_robots_launch_ends(started: Started, tmp_path: Path) -> None:
    launcher = started.sleeper()
    log = tmp_path / "talker.log"
    guardian, pid = started.guard(log, Lifetime(launch=_launch(launcher)))
    assert pid != guardian.pid and _alive(pid)
    assert os.getsid(pid) == pid  # a session of its own: stopped as a whole
    time.sleep(0.5)
    assert _alive(pid) and guardian.poll() is None  # the robot runs: so does the node
    launcher.kill()
    launcher.wait(5)
    assert _wait(lambda: not _alive(pid), 5) is not None, log.read_text()
    assert guardian.wait(5) == 0
    text = log.read_text()
    assert "the robot's launch process ended" in text and "stopped by SIGINT" in text, text


def test_a_launch_pid_reused_by_another_process_is_not_the_launch(started: Started) -> None:
    launch = _launch(started.sleeper())
    assert Watch(guardian_orders(launch), 0.0).why_stop(0.0) is None
    # The same pid with another start time: another process, so the launch has ended.
    reused = LaunchProcess(launch.pid, launch.start + 1, launch.what)
    assert "launch process ended" in (Watch(guardian_orders(reused), 0.0).why_stop(0.0) or "")


def _with(orders: Orders, **changes: Any) -> Orders:
    fields: dict[str, Any] = {k: getattr(orders, k) for k in Orders.__slots__}
    return Orders(**{**fields, **changes})


def guardian_orders(launch: LaunchProcess | None = None, **changes: Any) -> Orders:
    orders = Lifetime(launch=launch).orders("talker", ["true"], {}, Path("/dev/null"), None)
    return _with(orders, **changes)


def test_the_node_stops_once_the_master_is_gone_longer_than_the_bound(
    started: Started, master: FakeMaster, tmp_path: Path
) -> None:
    log = tmp_path / "talker.log"
    guardian, pid = started.guard(log, Lifetime(master_uri=master.uri, gone_s=1.0))
    time.sleep(1.5)
    assert _alive(pid)  # the master answers
    master.close()
    took = _wait(lambda: not _alive(pid), 6)
    assert took is not None, log.read_text()
    assert 0.9 <= took <= 3.0, took
    assert guardian.wait(5) == 0
    assert "the ROS master at" in log.read_text() and "has been gone" in log.read_text()


def test_a_short_master_restart_leaves_the_node_running(
    started: Started, master: FakeMaster, tmp_path: Path
) -> None:
    log = tmp_path / "talker.log"
    guardian, pid = started.guard(log, Lifetime(master_uri=master.uri, gone_s=2.5))
    time.sleep(0.5)
    master.close()
    time.sleep(1.2)  # the master restarts within the bound
    master.open()
    time.sleep(2.5)  # longer than the bound since the master went away
    assert _alive(pid) and guardian.poll() is None, log.read_text()
    master.close()  # and now for good
    assert _wait(lambda: not _alive(pid), 6) is not None, log.read_text()


def test_the_master_bound_counts_from_the_last_answer() -> None:
    """The same rule, on a clock of the test's own: gone at 10 s, back at 19.9 s, gone
    again at 25 s: stopped 30 s after 25 s, not 30 s after 10 s."""
    answers = {"up": True}
    orders = guardian_orders(master_uri="http://127.0.0.1:1/", gone_s=30.0, slow_poll_s=0.0)
    watch = Watch(orders, 0.0, master=lambda uri: answers["up"])
    timeline = [(0.0, True), (10.0, False), (19.9, True), (25.0, False)]
    stops = []
    for tenth in range(0, 700):
        t = tenth / 10
        answers["up"] = [up for at, up in timeline if at <= t][-1]
        if watch.why_stop(t) is not None:
            stops.append(t)
            break
    assert stops == [pytest.approx(54.9, abs=0.11)]


def test_the_node_stops_when_the_robots_other_nodes_are_all_gone(
    started: Started, tmp_path: Path
) -> None:
    # Names of this test run alone: other runs share the machine's process table.
    lst, cam, mapper = (f"{n}_{os.getpid()}" for n in ("listener", "camera", "mapper"))
    listener = started.sleeper("--ros-args", "-r", f"__node:={lst}")
    camera = started.sleeper("--ros-args", "-r", f"__node:={cam}", "-r", "__ns:=/front")
    # A node racc started (it names a guardian) is no sign of the robot.
    started.sleeper("--ros-args", "-r", f"__node:={mapper}", env={**os.environ, GUARDIAN_ENV: "1"})
    # Another robot's listener, in another ROS 2 domain, is no sign of this robot.
    started.sleeper("--ros-args", "-r", f"__node:={lst}", env={**os.environ, "ROS_DOMAIN_ID": "97"})
    domain = os.environ.get("ROS_DOMAIN_ID") or "0"
    assert _wait(lambda: listener.pid in node_pids([lst], domain), 5) is not None
    assert list(node_pids([lst], domain)) == [listener.pid]
    assert camera.pid in node_pids([f"front/{cam}"]) and not node_pids([cam])
    assert not node_pids([mapper])
    log = tmp_path / "talker.log"
    lifetime = Lifetime(others=(lst, f"front/{cam}", mapper, "talker"), gone_s=1.0)
    guardian, pid = started.guard(log, lifetime)
    listener.kill()
    listener.wait(5)
    time.sleep(1.5)
    assert _alive(pid), log.read_text()  # the camera still runs
    camera.kill()
    camera.wait(5)
    assert _wait(lambda: not _alive(pid), 5) is not None, log.read_text()
    assert guardian.wait(5) == 0
    assert "none of the robot's other nodes has run here" in log.read_text()


def test_other_nodes_never_seen_count_only_without_a_launch_process() -> None:
    """With the robot's launch process known, other nodes never seen here (they run on
    another machine) stop nothing; without one, a node started while none of the robot
    runs here (a repair that raced the robot's shutdown) is stopped after the bound."""
    launch = LaunchProcess(os.getpid(), process_start(os.getpid()) or 0, "this test")
    with_launch = guardian_orders(launch, others=("listener",), gone_s=1.0, slow_poll_s=0.0)
    watch = Watch(with_launch, 0.0, nodes=lambda names, domain: {})
    assert all(watch.why_stop(t / 10) is None for t in range(100))
    alone = guardian_orders(None, others=("listener",), gone_s=1.0, slow_poll_s=0.0)
    assert alone.others_from_start
    watch = Watch(alone, 0.0, nodes=lambda names, domain: {})
    stops = [t / 10 for t in range(30) if watch.why_stop(t / 10) is not None]
    assert stops[:1] == [1.0], stops


def test_a_stubborn_node_is_stopped_by_sigterm(started: Started, tmp_path: Path) -> None:
    launcher = started.sleeper()
    log = tmp_path / "talker.log"
    steps = ((signal.SIGINT, 0.5), (signal.SIGTERM, 2.0), (signal.SIGKILL, 1.0))
    argv = [sys.executable, "-c", STUBBORN]
    orders = Lifetime(launch=_launch(launcher)).orders("talker", argv, dict(os.environ), log, None)
    guardian, pid = start_guarded(_with(orders, stop_steps=steps, **FAST))
    started.procs.append(guardian)
    started.pids.append(pid)
    time.sleep(0.5)  # the node has set its handler
    launcher.kill()
    assert _wait(lambda: not _alive(pid), 6) is not None
    assert guardian.wait(5) == 0
    assert "stopped by SIGTERM" in log.read_text(), log.read_text()


def test_the_guardian_ends_with_its_node(started: Started, tmp_path: Path) -> None:
    launcher = started.sleeper()
    code = "import time; time.sleep(0.5)"
    guardian, pid = started.guard(tmp_path / "t.log", Lifetime(launch=_launch(launcher)), code)
    assert _wait(lambda: guardian.poll() is not None, 10) is not None
    assert guardian.returncode == 0 and not _alive(pid)
    assert "exited (0): done" in (tmp_path / "t.log").read_text()


def test_stopping_the_guardian_stops_its_node(started: Started, tmp_path: Path) -> None:
    guardian, pid = started.guard(tmp_path / "t.log", Lifetime())
    time.sleep(0.3)
    guardian.send_signal(signal.SIGTERM)
    assert _wait(lambda: not _alive(pid), 10) is not None
    assert guardian.wait(5) == 0


def test_a_node_that_cannot_start_is_rac111(tmp_path: Path) -> None:
    from rac.errors import RacError

    orders = Lifetime().orders("talker", [str(tmp_path / "missing")], {}, tmp_path / "l", None)
    with pytest.raises(RacError) as err:
        start_guarded(orders)
    assert err.value.diagnostics[0].code == "RAC111"
    assert "missing" in err.value.diagnostics[0].message


# -- finding the robot's launch process ---------------------------------------------------------


def _launch_name() -> str:
    """A launch file name of this run alone: a ``roslaunch PKG FILE`` is found by the file's
    name, so another run's ``roslaunch my_robot robot.launch`` on the machine (the test below,
    in a parallel run) would be this test's robot."""
    return f"robot_{os.getpid()}_{time.monotonic_ns()}.launch"


def _launcher(tmp: Path, name: str, args: Sequence[str], started: Started) -> int:
    exe = tmp / name
    exe.write_text(f"#!{sys.executable}\nimport time\ntime.sleep(120)\n", encoding="utf-8")
    exe.chmod(0o755)
    proc = subprocess.Popen([str(exe), *args], cwd=tmp)
    started.procs.append(proc)
    return proc.pid


def test_the_launch_process_is_found_by_its_launch_file(started: Started, tmp_path: Path) -> None:
    name = _launch_name()
    (tmp_path / name).write_text("<launch/>", encoding="utf-8")
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / name).write_text("<launch/>", encoding="utf-8")
    racc = _launcher(tmp_path, "racc", ["repairer", "m.yaml", "--launch", name], started)
    other = _launcher(tmp_path, "roslaunch", [f"other/{name}"], started)
    found: list[LaunchProcess | None] = [None]

    def seen() -> bool:
        found[0] = launch_process(str(tmp_path / name))
        return found[0] is not None

    assert _wait(seen, 1.0) is None  # racc's own --launch and another file: not the robot's
    ours = _launcher(tmp_path, "roslaunch", ["--wait", name], started)  # relative
    assert _wait(seen, 10) is not None
    assert found[0] is not None and found[0].pid == ours and "roslaunch of" in found[0].what
    assert found[0].start == process_start(ours)
    assert racc != other


def test_ros2_launch_and_racc_demo_are_launch_processes(started: Started, tmp_path: Path) -> None:
    xml = tmp_path / "robot.launch.xml"
    xml.write_text("<launch/>", encoding="utf-8")
    ros2 = _launcher(tmp_path, "ros2", ["launch", str(xml)], started)
    found = _wait(lambda: (launch_process(str(xml)) or LaunchProcess(0, 0, "")).pid == ros2, 10)
    assert found is not None
    demo_dir = tmp_path / "demo"
    demo_dir.mkdir()
    (demo_dir / "robot.launch.xml").write_text("<launch/>", encoding="utf-8")
    demo = _launcher(tmp_path, "racc", ["demo", "--ros", "2", "m.ram", "-o", "demo"], started)
    seen = _wait(
        lambda: (
            (launch_process(str(demo_dir / "robot.launch.xml")) or LaunchProcess(0, 0, "")).pid
            == demo
        ),
        10,
    )
    assert seen is not None
    assert launch_process(None) is None


def test_roslaunch_pkg_file_is_found_by_the_files_name(started: Started, tmp_path: Path) -> None:
    name = _launch_name()
    (tmp_path / name).write_text("<launch/>", encoding="utf-8")
    by_package = _launcher(tmp_path, "roslaunch", ["my_robot", name], started)
    target = str(tmp_path / name)
    found = _wait(lambda: (launch_process(target) or LaunchProcess(0, 0, "")).pid == by_package, 10)
    assert found is not None
    # A process that names the file's path wins over one that names the package's file.
    by_path = _launcher(tmp_path, "roslaunch", [target], started)
    found = _wait(lambda: (launch_process(target) or LaunchProcess(0, 0, "")).pid == by_path, 10)
    assert found is not None
