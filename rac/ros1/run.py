"""The processes a ROS 1 launch file names, as ``roslaunch`` would start them (``racc run``).

The file is read by roslaunch's own loader (``roslaunch.config``: every substitution and
``<include>`` it knows), its parameters are set on the master, and each ``<node>`` becomes
a command line: racc's own nodes run in this Python, others are found as roslaunch finds
them (``roslib.packages.find_node``).  The processes themselves are
:class:`rac.runtime.launcher.Supervisor`'s.
"""

from __future__ import annotations

import shlex
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rac.errors import Diagnostic, RacError
from rac.ros1.common import check_master, master_uri
from rac.runtime.launcher import NodeProcess, racc_command


def load_processes(path: Path, arguments: Mapping[str, str]) -> list[NodeProcess]:
    """The node processes of ``path`` with ``arguments`` set; its parameters go to the
    master (RAC058 without one, RAC059 when the file does not load)."""
    check_master()
    import roslaunch.config

    argv = [f"{k}:={v}" for k, v in arguments.items()]
    try:
        config = roslaunch.config.load_config_default([(str(path), argv)], None, verbose=False)
    except Exception as err:  # roslaunch raises many kinds for a bad file
        raise RacError([Diagnostic("RAC059", f"{path}: roslaunch cannot load it: {err}")]) from None
    _set_params(config)
    return [_process(node) for node in config.nodes]


def _set_params(config: Any) -> None:
    import rosgraph

    master = rosgraph.Master("/racc_run", master_uri=master_uri())
    for key, param in config.params.items():
        if key.startswith("/run_id") or key.startswith("/roslaunch"):
            continue
        master.setParam(key, param.value)


def _process(node: Any) -> NodeProcess:
    ns = str(node.namespace or "/")
    full = (ns.rstrip("/") + "/" + node.name).lstrip("/")
    start = racc_command(1, node.type) if node.package == "racc" else None
    if start is None:
        start = [_executable(node.package, node.type)]
    args = [*shlex.split(node.args or ""), *(f"{a}:={b}" for a, b in node.remap_args)]
    args.append(f"__name:={node.name}")
    if ns != "/":
        args.append(f"__ns:={ns}")
    return NodeProcess(
        full,
        (*start, *args),
        tuple((k, str(v)) for k, v in node.env_args),
        respawn=bool(node.respawn),
        respawn_delay=float(node.respawn_delay or 0.0),
    )


def _executable(package: str, node_type: str) -> str:
    import roslib.packages

    try:
        found = roslib.packages.find_node(package, node_type)
    except Exception as err:  # rospkg raises its own kinds for a missing package
        found, why = [], str(err)
    else:
        why = "not found"
    if not found:
        raise RacError(
            [
                Diagnostic(
                    "RAC131",
                    f"cannot find node type [{package}/{node_type}]: {why}",
                    hint="put the package on ROS_PACKAGE_PATH",
                )
            ]
        )
    return str(found[0])


def restart_problems(robot_launch: str) -> list[str]:
    """Why the repair engine could not restart nodes of ``robot_launch``: packages its
    ``<node>`` entries name that are not on ROS_PACKAGE_PATH (said before they are needed)."""
    import roslaunch.config
    import rospkg

    try:
        config = roslaunch.config.load_config_default([robot_launch], None, verbose=False)
    except Exception as err:  # roslaunch raises many kinds for a bad file
        return [f"{robot_launch}: roslaunch cannot load it: {err}"]
    problems = []
    packs = rospkg.RosPack()
    for package in sorted({n.package for n in config.nodes}):
        try:
            packs.get_path(package)
        except rospkg.ResourceNotFound:
            problems.append(
                f"package '{package}' of {robot_launch} is not on ROS_PACKAGE_PATH: the repair "
                "engine cannot restart its nodes (racc demo prints the export line for its own)"
            )
    return problems
