"""Old module paths that files outside racc still name, served by the modules now there.

The executables of a ``racc`` ROS package (``racc ros-package``) import racc's entry point;
packages written before it moved beside :mod:`rac.cli` say ``from rac.ros1.entry import
main``.  A robot that upgrades racc and keeps its package must keep starting, so importing
an old path gives the module at its new one (the same module object).  A name, not a code
dependency: no transport imports an entry point."""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from importlib.machinery import ModuleSpec
from types import ModuleType
from typing import TYPE_CHECKING, cast

if TYPE_CHECKING:
    from importlib.abc import Loader

# old path -> new path
MOVED = {
    "rac.ros1.entry": "rac.entry_ros1",
    "rac.ros2.entry": "rac.entry_ros2",
}


# The finder and loader follow importlib's protocols without its abstract classes:
# importlib.abc imports importlib.resources, 8 ms on every racc start.


class _MovedLoader:
    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: ModuleSpec) -> ModuleType:
        return importlib.import_module(self.new)

    def exec_module(self, module: ModuleType) -> None:
        """Already executed under its new name."""


class MovedFinder:
    """Finds the paths of :data:`MOVED` (after every other finder: a real module wins)."""

    def find_spec(
        self,
        fullname: str,
        path: Sequence[str] | None,
        target: ModuleType | None = None,
    ) -> ModuleSpec | None:
        new = MOVED.get(fullname)
        if new is None:
            return None
        return ModuleSpec(fullname, cast("Loader", _MovedLoader(new)))
