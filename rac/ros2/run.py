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
    return NodeProcess(
        node.key or node.executable,
        tuple(command),
        node.env,
        respawn=node.respawn,
        respawn_delay=node.respawn_delay,
    )


def restart_problems(robot_launch: str) -> list[str]:
    """Why the repair engine could not restart nodes of ``robot_launch``: packages its
    ``<node>`` entries name that are not in the ament index (said before they are needed)."""
    from rac.errors import RacError
    from rac.ros2.launch import package_prefix

    try:
        packages = sorted({n.package for n in load_launch(robot_launch)})
    except RacError as err:
        return [err.diagnostics[0].message]
    problems = []
    for package in packages:
        try:
            package_prefix(package)
        except RacError:
            problems.append(
                f"package '{package}' of {robot_launch} is not in the ament index: the repair "
                "engine cannot restart its nodes (put its prefix on AMENT_PREFIX_PATH; racc "
                "demo prints the export line for its own)"
            )
    return problems
