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
