"""The process probe's settling: a node's start-up is not judged by its cpu and memory."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator, Sequence

import psutil
import pytest

from rac.observe import NodeSample, PropertySample
from rac.runtime.procs import (
    DEFAULT_SETTLE_S,
    ProcessProbe,
    index_by_node,
    node_key,
    node_processes,
    seconds_since_boot,
    started_since_boot,
)

# Busy for BUSY_S (a start-up: imports, loading), then idle for good.
BUSY_S = 1.0
START_UP = (
    "import time\n"
    f"end = time.time() + {BUSY_S}\n"
    "while time.time() < end:\n"
    "    pass\n"
    "time.sleep(600)\n"
)


@pytest.fixture
def starting_node() -> Iterator[psutil.Process]:
    proc = subprocess.Popen([sys.executable, "-S", "-c", START_UP])
    try:
        yield psutil.Process(proc.pid)
    finally:
        proc.kill()
        proc.wait(10)


def kinds(events: Sequence[object]) -> list[str]:
    return [type(e).__name__ for e in events]


def test_a_young_process_is_running_but_has_no_properties_yet(
    starting_node: psutil.Process,
) -> None:
    start = started_since_boot(starting_node)
    now = [start + 1.0]
    probe = ProcessProbe(
        ["driver"],
        lambda _: starting_node.pid,
        [("driver", "cpu"), ("driver", "mem")],
        since_boot=lambda: now[0],
    )
    first = probe.sample(0.0)
    assert kinds(first) == ["NodeSample"]
    assert isinstance(first[0], NodeSample) and first[0].running
    now[0] = start + DEFAULT_SETTLE_S - 0.01
    assert kinds(probe.sample(0.1)) == ["NodeSample"]
    now[0] = start + DEFAULT_SETTLE_S
    assert kinds(probe.sample(0.2)) == ["NodeSample", "PropertySample", "PropertySample"]


def test_the_first_judged_cpu_sample_leaves_the_start_up_out(
    starting_node: psutil.Process,
) -> None:
    # Sampled through the busy start-up and past it; the first sample after settling
    # covers only the tick before it, not the time since the process was found.
    settle = BUSY_S + 1.5
    probe = ProcessProbe(
        ["driver"], lambda _: starting_node.pid, [("driver", "cpu")], settle_s=settle
    )
    samples: list[PropertySample] = []
    begun = time.monotonic()
    while not samples and time.monotonic() - begun < 30:
        samples += [e for e in probe.sample(time.monotonic()) if isinstance(e, PropertySample)]
        time.sleep(0.1)
    assert samples, "no cpu sample once the process had settled"
    assert seconds_since_boot() - started_since_boot(starting_node) >= settle
    assert samples[0].value < 25.0, f"the start-up's cpu leaked into {samples[0].value:.0f} %"


def test_settle_zero_judges_from_the_first_sample(starting_node: psutil.Process) -> None:
    probe = ProcessProbe(["driver"], lambda _: starting_node.pid, [("driver", "mem")], settle_s=0)
    assert kinds(probe.sample(0.0)) == ["NodeSample", "PropertySample"]


def test_a_process_age_is_exact_to_the_tick() -> None:
    # psutil's create_time, an epoch time, carries the boot time in whole seconds: as an
    # age it was up to 1 s too old, and the settling up to 1 s short.
    before = seconds_since_boot()
    proc = subprocess.Popen([sys.executable, "-S", "-c", "import time; time.sleep(60)"])
    try:
        started = started_since_boot(psutil.Process(proc.pid))
    finally:
        proc.kill()
        proc.wait(10)
    assert before - 0.02 <= started <= seconds_since_boot() + 0.02


class _Listed:
    """A process table's entry, as psutil.process_iter(attrs) gives it."""

    def __init__(self, pid: int, cmdline: list[str], created: float) -> None:
        self.pid = pid
        self.info = {"cmdline": cmdline, "create_time": created, "status": "sleeping"}


def test_the_table_indexed_by_node_finds_what_a_search_of_it_finds() -> None:
    """The observer host on ROS 2 looks a node up in an index of the process table built
    once per scan; it must find the processes a search of the table for that node does."""
    table = [
        _Listed(10, ["relay", "--ros-args", "-r", "__node:=relay_1"], 5.0),
        _Listed(11, ["python3", "talker", "--ros-args", "-r", "__node:=talker"], 3.0),
        _Listed(12, ["ros2", "run", "p", "talker", "--ros-args", "-r", "__node:=talker"], 2.0),
        _Listed(13, ["cam", "--ros-args", "-r", "__node:=cam", "-r", "__ns:=/front/"], 1.0),
        _Listed(
            14,
            ["cam", "--ros-args", "-r", "__ns:=/a", "-r", "__ns:=/rear", "-r", "__node:=cam"],
            1.0,
        ),
        _Listed(15, ["relay", "-r", "__node:=relay_10"], 5.0),
    ]
    index = index_by_node(table)  # type: ignore[arg-type]
    for node in (
        "relay_1",
        "relay_10",
        "talker",
        "/talker",
        "front/cam",
        "/rear/cam/",
        "cam",
        "a/cam",
        "nobody",
    ):
        searched = [p.pid for p in node_processes(node, table)]  # type: ignore[arg-type]
        indexed = [p.pid for p in index.get(node_key(node), [])]
        assert indexed == searched, node
    assert [p.pid for p in index[node_key("talker")]] == [12, 11]  # oldest first


def test_the_kept_process_table_sees_a_node_start_and_end() -> None:
    from rac.runtime.procs import ProcessTable

    table = ProcessTable()
    name = f"racc_test_table_{time.monotonic_ns()}"
    assert not any(f"__node:={name}" in p.info["cmdline"] for p in table.scan())
    args = [sys.executable, "-S", "-c", "import time; time.sleep(60)", "--ros-args", "-r"]
    proc = subprocess.Popen([*args, f"__node:={name}"])
    try:
        deadline = time.time() + 10
        found: list[int] = []
        while not found and time.time() < deadline:
            found = [p.pid for p in table.scan() if f"__node:={name}" in p.info["cmdline"]]
        assert found == [proc.pid]
    finally:
        proc.kill()
        proc.wait(10)
    assert not any(f"__node:={name}" in p.info["cmdline"] for p in table.scan())
