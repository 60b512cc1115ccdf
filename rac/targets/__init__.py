"""Emitters, registered by target name: each is a pure ``(Compiled, EmitOptions) -> str``.

``TARGETS`` fixes the file each target writes (docs/spec.md) and the order the
CLI emits them in.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

from rac.perf import paused_gc
from rac.pipeline import Compiled

DEFAULT_OBSERVERS_PACKAGE = "tug_ist_diagnosis_observers"
DEFAULT_MODEL_SERVER_PACKAGE = "tug_ist_diagnosis_model"


@dataclass(frozen=True, slots=True)
class EmitOptions:
    """Knobs a user may turn from the command line.

    With neither package given, both launch files start racc's own runtime (the ``racc``
    ROS 1 or ROS 2 package); naming either one selects the dissertation's stack of one node
    per observer and a model server, with the other package at its default.
    """

    observers_package: str | None = None
    model_server_package: str | None = None
    # Per component, the fault modes no observer detects (racc analyze's analysis, which a
    # command runs: targets do not call engines), outlined on architecture.dot; None: not
    # analysed, and the diagram says so.
    undetected: tuple[tuple[str, tuple[str, ...]], ...] | None = None

    @property
    def stack(self) -> bool:
        return self.observers_package is not None or self.model_server_package is not None

    @property
    def observers(self) -> str:
        return self.observers_package or DEFAULT_OBSERVERS_PACKAGE

    @property
    def model_server(self) -> str:
        return self.model_server_package or DEFAULT_MODEL_SERVER_PACKAGE


Emitter = Callable[[Compiled, EmitOptions], str]


@dataclass(frozen=True, slots=True)
class Target:
    name: str
    filename: str
    emit: Emitter
    description: str


def _registry() -> tuple[Target, ...]:
    from rac.targets import dot, launch_ros1, launch_ros2, model_yaml, observers_yaml, pddl_domain

    return (
        Target("model", "model.yaml", model_yaml.emit_model_yaml, "diagnosis model server file"),
        Target(
            "observers", "observers.yaml", observers_yaml.emit_observers_yaml, "observers model"
        ),
        Target("ros1", "observers.launch", launch_ros1.emit_launch_ros1, "ROS 1 launch file"),
        Target("ros2", "observers.launch.xml", launch_ros2.emit_launch_ros2, "ROS 2 launch file"),
        Target("pddl", "repair_domain.pddl", pddl_domain.emit_repair_domain, "PDDL repair domain"),
        Target("dot", "architecture.dot", dot.emit_dot, "Graphviz architecture diagram"),
    )


def _paused_gc(emit: Emitter) -> Emitter:
    """The emitter with the cyclic GC paused while it runs (see :mod:`rac.perf`)."""

    @functools.wraps(emit)
    def run(compiled: Compiled, options: EmitOptions) -> str:
        with paused_gc():
            return emit(compiled, options)

    return run


def targets() -> tuple[Target, ...]:
    return tuple(Target(t.name, t.filename, _paused_gc(t.emit), t.description) for t in _registry())


def emit_all(compiled: Compiled, options: EmitOptions) -> dict[str, str]:
    """Every target's text, keyed by file name, in registry order."""
    return {t.filename: t.emit(compiled, options) for t in targets()}
