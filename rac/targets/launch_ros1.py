"""observers.launch: ROS 1 roslaunch XML starting racc's runtime, or (with a package named)
the dissertation's model server and one node per observer."""

from __future__ import annotations

from rac.pipeline import Compiled
from rac.targets.launch_common import render_launch, render_runtime_launch
from rac.targets.options import EmitOptions


def emit_launch_ros1(compiled: Compiled, options: EmitOptions) -> str:
    if not options.stack:
        return render_runtime_launch(compiled)
    return render_launch("observers.launch.j2", compiled, options)
