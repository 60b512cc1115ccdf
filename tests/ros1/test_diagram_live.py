"""racc diagram --live on a real ROS 1 master: the latched /diagnosis and /observations, as
racc's runtime publishes them, drawn on the architecture.

Skipped (with the reason) where ROS 1 is not importable; CI's ROS venv sets RACC_REQUIRE_ROS=1.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

if os.environ.get("RACC_REQUIRE_ROS") == "1":
    import rospy  # noqa: F401
else:
    pytest.importorskip("rospy", reason="ROS 1 (python3-rospy) is not importable")
if shutil.which("roscore") is None:
    if os.environ.get("RACC_REQUIRE_ROS") == "1":
        raise RuntimeError("roscore is not installed")
    pytest.skip("roscore is not installed", allow_module_level=True)

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
RACC = [sys.executable, "-m", "rac"]

# A node of our own publishing what racc's engine and observer host publish, latched: the
# rows come from rac.runtime.status, the messages from rac.ros1.common, as in the runtime.
PUBLISHER = """
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from rac.logic import Atom
from rac.observe import Verdict
from rac.ros1.common import to_array
from rac.runtime.status import Row, literal_row
rospy.init_node("fake_runtime")
diagnosis = rospy.Publisher("/diagnosis", DiagnosticArray, queue_size=1, latch=True)
observations = rospy.Publisher("/observations", DiagnosticArray, queue_size=1, latch=True)
rows = [literal_row(Verdict(1.0, Atom("ok", ("pose",)), False), "pose_gobs"),
        literal_row(Verdict(1.0, Atom("running", ("jaguar_node",)), True), "jaguar_node_nobs")]
observations.publish(to_array(rows))
bad = (("bad", "jaguar_node"), ("good", ""))
diagnosis.publish(to_array([Row("diagnosis 1", 2, "jaguar_node", "tedusar", bad)]))
print("published", flush=True)
rospy.spin()
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


@pytest.fixture
def master(tmp_path: Path) -> Iterator[dict[str, str]]:
    port = free_port()
    env = dict(os.environ)
    env.update(
        ROS_MASTER_URI=f"http://127.0.0.1:{port}",
        ROS_IP="127.0.0.1",
        ROS_HOME=str(tmp_path / "ros_home"),
        PYTHONUNBUFFERED="1",
    )
    core = subprocess.Popen(
        ["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        import rosgraph

        deadline = time.time() + 30
        while not rosgraph.is_master_online(env["ROS_MASTER_URI"]) and time.time() < deadline:
            time.sleep(0.2)
        assert rosgraph.is_master_online(env["ROS_MASTER_URI"]), "roscore did not come up"
        yield env
    finally:
        stop(core)


def test_live_snapshot_colours_what_the_runtime_says(
    master: dict[str, str], tmp_path: Path
) -> None:
    nothing = subprocess.run(
        [*RACC, "diagram", TEDUSAR, "--live", "--ros", "1", "--timeout", "1"],
        env=master,
        capture_output=True,
        timeout=60,
    )
    assert nothing.returncode == 1 and b"error[RAC069]" in nothing.stderr
    fake = subprocess.Popen(
        [sys.executable, "-c", PUBLISHER],
        env=master,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        assert fake.stdout is not None
        assert fake.stdout.readline().strip() == b"published"
        out = tmp_path / "live.dot"
        done = subprocess.run(
            [*RACC, "diagram", TEDUSAR, "--live", "--ros", "1", "-o", str(out), "-q"],
            env=master,
            capture_output=True,
            timeout=60,
        )
        assert done.returncode == 0, done.stderr.decode()
    finally:
        stop(fake)
    text = out.read_text()
    assert "live at " in text and "2 observations, 1 bad: minimal diagnoses {jaguar_node}" in text
    jaguar = next(line for line in text.splitlines() if line.strip().startswith('"jaguar_node" ['))
    assert 'fillcolor="#e53935"' in jaguar and 'color="#2e7d32"' in jaguar  # faulty, running
    pose = next(line for line in text.splitlines() if "/pose @ 10 Hz" in line and "label=" in line)
    assert 'COLOR="#c62828"' in pose
