"""What a user may choose about the emitted files (the emitters' second argument).

Its own module so that each emitter imports it without importing the registry of
emitters in ``rac.targets``, which imports every emitter.
"""

from __future__ import annotations

from dataclasses import dataclass

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
