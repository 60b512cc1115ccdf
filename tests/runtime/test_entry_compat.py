"""A racc ROS package written before the entry points moved beside rac.cli still starts:
its scripts import ``rac.ros1.entry`` / ``rac.ros2.entry``."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

OLD_SCRIPT = (
    "import sys\n\n"
    "from rac.ros{version}.entry import main\n\n"
    "sys.exit(main('observe', sys.argv[1:]))\n"
)


@pytest.mark.parametrize("version", [1, 2])
def test_a_script_of_an_older_package_still_runs(version: int) -> None:
    done = subprocess.run(
        [sys.executable, "-c", OLD_SCRIPT.format(version=version), "--help"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage: racc observe")


BODY_FIRST = """
import json, sys
import rac.entry_ros{version} as entry
HEAVY = ("numpy", "rclpy", "rospy", "rac.cli", "rac.runtime.demo", "rac.ros{version}.common")
seen = []
class Started(Exception):
    pass
def start_body(marker):
    seen.append([list(marker), [m for m in HEAVY if m in sys.modules]])
    raise Started
entry.start_body = start_body
try:
    entry.main("demo-node", {argv!r})
except Started:
    pass
print(json.dumps(seen))
"""
DEMO_ARGV = {
    1: ["model.ram", "imu_node", "--epoch", "0", "__name:=imu_node", "__log:=/tmp/x.log"],
    2: ["model.ram", "imu_node", "--epoch", "0", "--ros-args", "-r", "__node:=imu_node"],
}
MARKER = {1: ["__name:=imu_node"], 2: ["--ros-args", "-r", "__node:=imu_node"]}


@pytest.mark.parametrize("version", [1, 2])
def test_a_demo_node_starts_its_body_before_the_heavy_imports(version: int) -> None:
    # Until a demo node's body has settled, its cpu and memory are not judged (racc
    # observe --settle); and on ROS 2, until the body exists, the node's own process is
    # the one measured.  Importing racc and rclpy under load takes seconds (the bring-up
    # false repairs on a loaded CI machine), so the body starts first.
    script = BODY_FIRST.format(version=version, argv=DEMO_ARGV[version])
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == [[MARKER[version], []]]
