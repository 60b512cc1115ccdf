"""ROS 2's part of a command line, apart from racc's: standard library only, since the
demo node reads it before anything else is imported (:mod:`rac.entry_ros2`)."""

from __future__ import annotations

from collections.abc import Sequence

# ROS arguments (``--ros-args -r __node:=NAME ...``) of this process: the executables of
# the racc package put them here (:mod:`rac.entry_ros2`) before running a racc command.
ROS_ARGS: list[str] = []


def split_ros_args(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """(racc's arguments, ROS 2's): ``--ros-args ... [--]`` is ROS 2's, as rclpy reads it."""
    mine: list[str] = []
    ros: list[str] = []
    inside = False
    for a in argv:
        if a == "--ros-args":
            inside = True
            ros.append(a)
        elif inside and a == "--":
            inside = False
        elif inside:
            ros.append(a)
        else:
            mine.append(a)
    return mine, ros
