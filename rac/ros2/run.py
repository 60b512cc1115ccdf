"""The processes a ROS 2 launch XML file names, as ``ros2 launch`` would start them
(``racc run --ros 2``): read by :func:`rac.ros2.launch.load_launch`, racc's own nodes run
in this Python (no ament prefix needed for them), others from the ament index.  The
processes themselves are :class:`rac.runtime.launcher.Supervisor`'s.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from rac.ros2.launch import LaunchNode, command_line, load_launch, node_arguments
from rac.runtime.launcher import NodeProcess, racc_command


def load_processes(path: Path, arguments: Mapping[str, str]) -> list[NodeProcess]:
    """The node processes of ``path`` with ``arguments`` set (RAC117/RAC118 otherwise)."""
    return [_process(node) for node in load_launch(path, arguments)]


def _process(node: LaunchNode) -> NodeProcess:
    start = racc_command(2, node.executable) if node.package == "racc" else None
    command = command_line(node) if start is None else [*start, *node_arguments(node)]
    return NodeProcess(node.key or node.executable, tuple(command), node.env)
