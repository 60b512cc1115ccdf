"""A racc ROS package written before the entry points moved beside rac.cli still starts:
its scripts import ``rac.ros1.entry`` / ``rac.ros2.entry``."""

from __future__ import annotations

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


def test_the_ros2_entry_starts_a_demo_body_before_the_heavy_imports() -> None:
    # Until a demo node's body exists, the node's own process is the one the observers
    # measure; importing racc and rclpy under load takes seconds, far over a driver's cpu
    # and memory limits (the bring-up false repairs on a loaded CI machine).
    probe = (
        "import sys\n"
        "import rac.entry_ros2\n"
        "heavy = [m for m in ('numpy', 'rclpy', 'rac.cli', 'rac.runtime.demo', 'lark')"
        " if m in sys.modules]\n"
        "print(','.join(heavy))\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "", f"imported before the body starts: {done.stdout}"
