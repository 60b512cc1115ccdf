"""racc diagram --live --ros 2 with real rclpy processes: the latched (transient local)
/diagnosis and /observations, as racc's runtime publishes them, drawn on the architecture.

Self-contained (its own domain, its own processes, stopped by pid); skipped like
test_live.py where rclpy is missing, and CI's ROS 2 venv sets RACC_REQUIRE_ROS2=1.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

if os.environ.get("RACC_REQUIRE_ROS2") == "1":
    import rclpy  # noqa: F401
else:
    pytest.importorskip("rclpy", reason="ROS 2 (rclpy) is not importable")

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
RACC = [sys.executable, "-m", "rac"]
PROFILE = Path(__file__).with_name("fastdds_localhost.xml")

# A process of our own publishing what racc's engine and observer host publish, latched:
# the rows from rac.runtime.status, the messages and QoS from rac.ros2.common, as the
# runtime does.
PUBLISHER = """
import signal, threading
from rac.logic import Atom
from rac.observe import Verdict
from rac.ros2.common import Session
from rac.runtime.status import Row, literal_row
session = Session("fake_runtime")
observations = session.rows_publisher("/observations", 50, latched=True)
diagnosis = session.rows_publisher("/diagnosis", 10, latched=True)
observations([literal_row(Verdict(1.0, Atom("ok", ("pose",)), False), "pose_gobs"),
              literal_row(Verdict(1.0, Atom("running", ("jaguar_node",)), True),
                          "jaguar_node_nobs")])
bad = (("bad", "jaguar_node"), ("good", ""))
diagnosis([Row("diagnosis 1", 2, "jaguar_node", "tedusar", bad)])
print("published", flush=True)
stop = threading.Event()
signal.signal(signal.SIGINT, lambda *_: stop.set())
while session.ok and not stop.wait(0.2):
    pass
session.close()
"""


def ros2_env(tmp_path: Path) -> dict[str, str]:
    """A domain of this test's own, discovery on this host only."""
    env = {k: v for k, v in os.environ.items() if "DEFAULT_PROFILES_FILE" not in k}
    env.update(
        ROS_DOMAIN_ID=str((os.getpid() + 53) % 100 + 1),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_LOG_DIR=str(tmp_path / "ros_log"),
        FASTDDS_DEFAULT_PROFILES_FILE=str(PROFILE),
        PYTHONUNBUFFERED="1",
    )
    return env


def stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


def test_live_snapshot_on_ros2_colours_what_the_runtime_says(tmp_path: Path) -> None:
    env = ros2_env(tmp_path)
    nothing = subprocess.run(
        [*RACC, "diagram", TEDUSAR, "--live", "--ros", "2", "--timeout", "1"],
        env=env,
        capture_output=True,
        timeout=90,
    )
    assert nothing.returncode == 1 and b"error[RAC069]" in nothing.stderr, nothing.stderr
    fake = subprocess.Popen(
        [sys.executable, "-c", PUBLISHER],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        assert fake.stdout is not None
        first = fake.stdout.readline().strip()
        assert first == b"published", first
        out = tmp_path / "live.dot"
        # discovery on a loaded 2-core machine can take seconds: a generous timeout
        live = ["--live", "--ros", "2", "--timeout", "30", "-o", str(out), "-q"]
        done = subprocess.run(
            [*RACC, "diagram", TEDUSAR, *live],
            env=env,
            capture_output=True,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr.decode()
    finally:
        stop(fake)
    text = out.read_text()
    assert "live at " in text and "2 observations, 1 bad: minimal diagnoses {jaguar_node}" in text
    jaguar = next(line for line in text.splitlines() if line.strip().startswith('"jaguar_node" ['))
    assert 'fillcolor="#e53935"' in jaguar and 'color="#2e7d32"' in jaguar  # faulty, running
    pose = next(line for line in text.splitlines() if "/pose @ 10 Hz" in line and "label=" in line)
    assert 'COLOR="#c62828"' in pose  # its rate observer reads bad
