"""roslaunch's part of a command line, apart from racc's: standard library only, since the
demo node reads it before anything else is imported (:mod:`rac.entry_ros1`)."""

from __future__ import annotations

from collections.abc import Sequence


def strip_ros_args(argv: Sequence[str]) -> list[str]:
    """The command line without roslaunch's ``__name:=…``, ``__log:=…`` and remappings."""
    return [a for a in argv if ":=" not in a]


def node_name_arg(argv: Sequence[str]) -> str | None:
    """roslaunch's ``__name:=NAME`` (the node's base name), if the line has one."""
    names = [a for a in argv if a.startswith("__name:=")]
    return names[-1] if names else None
