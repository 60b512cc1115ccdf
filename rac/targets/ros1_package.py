"""The ``racc`` ROS 1 package: a package.xml and thin executables, so that roslaunch finds
``<node pkg="racc" type="observe">`` and the others (``racc ros-package`` writes it).

Each executable starts with the interpreter that wrote it (a venv that sees Debian's ROS
packages), never ``#!/usr/bin/env python3``, drops roslaunch's ``__name:=…`` arguments and
runs the racc command of the same name.
"""

from __future__ import annotations

import sys

PACKAGE = "racc"
EXECUTABLES = {  # executable -> racc command (demo_node: rac.entry_ros1's own)
    "observe": "observe",
    "engine": "engine",
    "repairer": "repairer",
    "board_client": "board-client",
    "demo_node": "demo-node",
}

PACKAGE_XML = """<?xml version="1.0"?>
<package format="2">
  <name>racc</name>
  <version>{version}</version>
  <description>racc's ROS 1 runtime: observer host, diagnosis engine, repair engine, board
    client and demo robot nodes (thin executables around the racc Python package).</description>
  <maintainer email="racc@example.org">racc</maintainer>
  <license>MIT</license>
  <buildtool_depend>catkin</buildtool_depend>
  <exec_depend>rospy</exec_depend>
  <exec_depend>roslaunch</exec_depend>
  <exec_depend>diagnostic_msgs</exec_depend>
</package>
"""


def package_files(python: str | None = None) -> dict[str, str]:
    """Relative path -> text; the executables run ``python`` (default: this interpreter)."""
    from rac import __version__

    interpreter = python or sys.executable
    files = {"racc/package.xml": PACKAGE_XML.format(version=__version__)}
    for exe, command in EXECUTABLES.items():
        files[f"racc/scripts/{exe}"] = (
            f"#!{interpreter}\n"
            f"# racc's ROS 1 node '{exe}', written by 'racc ros-package'.\n"
            "import sys\n\n"
            "from rac.entry_ros1 import main\n\n"
            f"sys.exit(main({command!r}, sys.argv[1:]))\n"
        )
    return files
