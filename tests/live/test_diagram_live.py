"""racc diagram --live on a real ROS graph, once per ROS version (tests/live/conftest.py): the
latched /diagnosis and /observations, as racc's runtime publishes them, drawn on the
architecture.  A process of the test's own publishes them, with the rows of
rac.runtime.status and the messages of rac.ros1.common / rac.ros2.common, as the runtime
does."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from live_harness import TEDUSAR, Ros, environment, start_roscore
from soak_support import RACC, Processes

ROWS = """
from rac.logic import Atom
from rac.observe import Verdict
from rac.runtime.status import Row, literal_row
rows = [literal_row(Verdict(1.0, Atom("ok", ("pose",)), False), "pose_gobs"),
        literal_row(Verdict(1.0, Atom("running", ("jaguar_node",)), True), "jaguar_node_nobs")]
bad = [Row("diagnosis 1", 2, "jaguar_node", "tedusar", (("bad", "jaguar_node"), ("good", "")))]
"""

PUBLISHERS = {
    1: ROWS
    + """
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from rac.ros1.common import to_array
rospy.init_node("fake_runtime")
diagnosis = rospy.Publisher("/diagnosis", DiagnosticArray, queue_size=1, latch=True)
observations = rospy.Publisher("/observations", DiagnosticArray, queue_size=1, latch=True)
observations.publish(to_array(rows))
diagnosis.publish(to_array(bad))
print("published", flush=True)
rospy.spin()
""",
    2: ROWS
    + """
import signal, threading
from rac.ros2.common import Session
session = Session("fake_runtime")
session.rows_publisher("/observations", 50, latched=True)(rows)
session.rows_publisher("/diagnosis", 10, latched=True)(bad)
print("published", flush=True)
stop = threading.Event()
signal.signal(signal.SIGINT, lambda *_: stop.set())
while session.ok and not stop.wait(0.2):
    pass
session.close()
""",
}


@pytest.fixture
def graph(ros: Ros, tmp_path: Path) -> Iterator[tuple[dict[str, str], Processes]]:
    """A ROS graph of this test's own: a roscore on a free port, or a domain of its own."""
    env = environment(ros, tmp_path)
    procs = Processes(env, tmp_path)
    try:
        if ros.version == 1:
            start_roscore(procs, env)
        yield env, procs
    finally:
        procs.stop_all()


def _diagram(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[bytes]:
    # discovery on a loaded 2-core machine can take seconds: generous time-outs
    return subprocess.run(
        [*RACC, "diagram", str(TEDUSAR), "--live", *args],
        env=env,
        capture_output=True,
        timeout=120,
    )


def test_live_snapshot_colours_what_the_runtime_says(
    ros: Ros, graph: tuple[dict[str, str], Processes], tmp_path: Path
) -> None:
    env, procs = graph
    version = ["--ros", str(ros.version)]
    nothing = _diagram(env, *version, "--timeout", "1")
    assert nothing.returncode == 1 and b"error[RAC069]" in nothing.stderr, nothing.stderr
    fake = procs.start(
        [sys.executable, "-c", PUBLISHERS[ros.version]], "fake.log", stdout=subprocess.PIPE
    )
    assert fake.stdout is not None
    first = fake.stdout.readline().strip()
    assert first == b"published", (first, (tmp_path / "fake.log").read_text())
    out = tmp_path / "live.dot"
    done = _diagram(env, *version, "--timeout", "30", "-o", str(out), "-q")
    assert done.returncode == 0, done.stderr.decode()
    text = out.read_text()
    assert "live at " in text and "2 observations, 1 bad: minimal diagnoses {jaguar_node}" in text
    jaguar = next(line for line in text.splitlines() if line.strip().startswith('"jaguar_node" ['))
    assert 'fillcolor="#e53935"' in jaguar and 'color="#2e7d32"' in jaguar  # faulty, running
    pose = next(line for line in text.splitlines() if "/pose @ 10 Hz" in line and "label=" in line)
    assert 'COLOR="#c62828"' in pose  # its rate observer reads bad
