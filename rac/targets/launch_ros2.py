"""observers.launch.xml: the ROS 2 XML launch equivalent of observers.launch."""

from __future__ import annotations

from rac.pipeline import Compiled
from rac.targets import EmitOptions
from rac.targets.launch_common import render_launch


def emit_launch_ros2(compiled: Compiled, options: EmitOptions) -> str:
    return render_launch("observers.launch.xml.j2", compiled, options)
