"""What the ROS 1 and ROS 2 launch emitters share: the observer nodes to start."""

from __future__ import annotations

from dataclasses import dataclass

from rac.pipeline import Compiled
from rac.targets import EmitOptions
from rac.targets.templating import render, xmlparams

MODEL_SERVER_EXECUTABLE = "diagnosis_model_server.py"
MODEL_SERVER_NAME = "diagnosis_model_server"


@dataclass(frozen=True, slots=True)
class LaunchNode:
    package: str
    executable: str
    name: str
    params_xml: str  # the node's <param> lines, already escaped


def param_text(value: object) -> str:
    if isinstance(value, float):
        return repr(value)
    return str(value)


def launch_nodes(compiled: Compiled, options: EmitOptions) -> tuple[LaunchNode, ...]:
    """The observer nodes, computed once per compilation for both launch files."""
    key = ("launch_nodes", options)
    cached = compiled.memo.get(key)
    if cached is None:
        cached = compiled.memo[key] = tuple(
            LaunchNode(
                options.observers_package,
                f"{o.kind}.py",
                o.name,
                xmlparams((k, param_text(v)) for k, v in o.params),
            )
            for o in compiled.observers
        )
    assert isinstance(cached, tuple)
    return cached


def render_launch(template: str, compiled: Compiled, options: EmitOptions) -> str:
    """A launch file starting the model server on model.yaml and every observer."""
    return render(
        template,
        robot=compiled.model.name.value,
        model_package=options.model_server_package,
        model_executable=MODEL_SERVER_EXECUTABLE,
        model_name=MODEL_SERVER_NAME,
        nodes=launch_nodes(compiled, options),
    )
