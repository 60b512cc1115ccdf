"""Faults files (``*.faults.yaml``, the ground truth ``racc synth`` writes beside a run)."""

from __future__ import annotations

from pathlib import Path

from rac.load.files import read_text
from rac.load.kinds import FAULTS, check_kind
from rac.synth.truth import GroundTruth, parse_truth


def load_truth(path: str | Path) -> GroundTruth:
    """Read and parse a faults file (RAC085 when it cannot be read)."""
    check_kind(path, FAULTS, "RAC085")
    return parse_truth(read_text(path, "RAC085"), str(path))
