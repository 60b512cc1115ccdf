"""Kept for ``racc`` ROS 2 packages written by racc 0.x before the entry point moved to
:mod:`rac.entry_ros2`: their scripts say ``from rac.ros2.entry import main``.  A robot
that upgrades racc but keeps its package keeps working; ``racc ros-package`` writes the
new import (docs/runtime.md).  The one import from a transport up to an entry point, listed
in pyproject.toml's import-linter contract."""

from __future__ import annotations

from rac.entry_ros2 import main

__all__ = ["main"]
