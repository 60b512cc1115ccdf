"""``racc synth``: synthetic recordings of the robot a model describes (for demos and tests).

The names below load on first use (PEP 562), so that the command line's start-up does
not import rosbags.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "Plan": "rac.synth.recording",
    "SynthOptions": "rac.synth.recording",
    "plan_recording": "rac.synth.recording",
    "write_recording": "rac.synth.recording",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'rac.synth' has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name]), name)
