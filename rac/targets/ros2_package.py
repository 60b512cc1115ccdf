"""The ``racc`` ROS 2 package, installed into a prefix: an ament index entry, a
package.xml and thin executables, so that ``ros2 launch`` finds ``<node pkg="racc"
exec="observe">`` and the others, and ``ros2 run racc observe ...`` works
(``racc ros-package --ros 2 -o PREFIX`` writes it).

Layout (what colcon would install for an ament_python package)::

    PREFIX/share/ament_index/resource_index/packages/racc   (empty: the index entry)
    PREFIX/share/racc/package.xml
    PREFIX/lib/racc/{observe,engine,repairer,board_client,demo_node,record}

Each executable starts with the interpreter that wrote it (a Python that imports rclpy)
and runs the racc command of the same name with ``--ros 2``; ROS arguments
(``--ros-args -r __node:=NAME ...``) go to rclpy.
"""

from __future__ import annotations

import sys

from rac.targets import ros1_package
from rac.targets.ros1_package import PACKAGE

# executable -> racc command: ROS 1's, and the recorder (ROS 1 records with racc record)
EXECUTABLES = {**ros1_package.EXECUTABLES, "record": "record"}

PACKAGE_XML = """<?xml version="1.0"?>
<package format="3">
  <name>racc</name>
  <version>{version}</version>
  <description>racc's ROS 2 runtime: observer host, diagnosis engine, repair engine, board
    client, recorder and demo robot nodes (thin executables around the racc Python
    package).</description>
  <maintainer email="racc@example.org">racc</maintainer>
  <license>MIT</license>
  <exec_depend>rclpy</exec_depend>
  <exec_depend>diagnostic_msgs</exec_depend>
  <exec_depend>std_msgs</exec_depend>
  <export>
    <build_type>ament_python</build_type>
  </export>
</package>
"""


def package_files(python: str | None = None) -> dict[str, str]:
    """Path relative to the prefix -> text; the executables run ``python``."""
    from rac import __version__

    interpreter = python or sys.executable
    files = {
        f"share/ament_index/resource_index/packages/{PACKAGE}": "",
        f"share/{PACKAGE}/package.xml": PACKAGE_XML.format(version=__version__),
    }
    for exe, command in EXECUTABLES.items():
        files[f"lib/{PACKAGE}/{exe}"] = (
            f"#!{interpreter}\n"
            f"# racc's ROS 2 node '{exe}', written by 'racc ros-package --ros 2'.\n"
            "import sys\n\n"
            "try:\n"
            "    from rac.entry_ros2 import main\n"
            "except KeyboardInterrupt:  # stopped while starting: as clean an end as later\n"
            "    sys.exit(0)\n\n"
            f"sys.exit(main({command!r}, sys.argv[1:]))\n"
        )
    return files
