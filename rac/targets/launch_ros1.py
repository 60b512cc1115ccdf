"""observers.launch: ROS 1 roslaunch XML starting the model server and every observer."""

from __future__ import annotations

from rac.pipeline import Compiled
from rac.targets import EmitOptions
from rac.targets.launch_common import MODEL_SERVER_EXECUTABLE, MODEL_SERVER_NAME, launch_nodes
from rac.targets.templating import render


def emit_launch_ros1(compiled: Compiled, options: EmitOptions) -> str:
    return render(
        "observers.launch.j2",
        robot=compiled.model.name.value,
        model_package=options.model_server_package,
        model_executable=MODEL_SERVER_EXECUTABLE,
        model_name=MODEL_SERVER_NAME,
        nodes=launch_nodes(compiled, options),
    )
