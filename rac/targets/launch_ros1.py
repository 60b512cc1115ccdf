"""observers.launch: ROS 1 roslaunch XML starting the model server and every observer."""

from __future__ import annotations

from rac.pipeline import Compiled
from rac.targets import EmitOptions
from rac.targets.launch_common import render_launch


def emit_launch_ros1(compiled: Compiled, options: EmitOptions) -> str:
    return render_launch("observers.launch.j2", compiled, options)
