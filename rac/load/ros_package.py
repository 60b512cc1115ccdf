"""The ``racc`` ROS packages (``racc ros-package``, ``racc demo``) written to disk."""

from __future__ import annotations

from pathlib import Path

from rac.errors import Diagnostic, RacError
from rac.targets import ros1_package, ros2_package


def write_package(out: Path, python: str | None = None, ros: int = 1) -> Path:
    """Write the ``racc`` ROS package (:mod:`rac.targets.ros1_package`, ``ros2_package``):
    the package's directory (ROS 1) or the prefix it is installed in (ROS 2)."""
    package_files = ros2_package.package_files if ros == 2 else ros1_package.package_files
    try:
        for rel, text in package_files(python).items():
            path = out / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
            if "/scripts/" in rel or rel.startswith("lib/"):
                path.chmod(0o755)
    except OSError as err:
        raise RacError([Diagnostic("RAC004", f"{out}: cannot write: {err}")]) from None
    return out if ros == 2 else out / "racc"
