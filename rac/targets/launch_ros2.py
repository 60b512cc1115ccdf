"""observers.launch.xml: ROS 2 launch XML starting racc's runtime (the ``racc`` ROS 2
package), or (with a package named) the dissertation's model server and one node per
observer, as observers.launch does for ROS 1."""

from __future__ import annotations

from rac.pipeline import Compiled
from rac.targets.launch_common import render_launch, render_runtime_launch
from rac.targets.options import EmitOptions


def emit_launch_ros2(compiled: Compiled, options: EmitOptions) -> str:
    if not options.stack:
        return render_runtime_launch(compiled, "runtime.launch.xml.j2")
    return render_launch("observers.launch.xml.j2", compiled, options)
