"""tug_diagnosis configurations (``racc import tug``), read into a model."""

from __future__ import annotations

from rac.load.files import read_text
from rac.load.kinds import TUG, check_kind
from rac.tug import DEFAULT_RATE_HZ, Imported, import_tug


def load_tug(path: str, robot: str, default_rate: float = DEFAULT_RATE_HZ) -> Imported:
    check_kind(path, TUG, "RAC064")
    return import_tug(read_text(path), path, robot, default_rate)
