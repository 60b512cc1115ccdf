"""``racc learn``: learn a model from recorded fault-free runs (chapter 9).

The names below load on first use (PEP 562): the command line imports the light
``rac.learn.options`` at start-up without paying for NumPy and rosbags.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "LearnResult": "rac.learn.learner",
    "learn": "rac.learn.learner",
    "observer_counts": "rac.learn.learner",
    "report": "rac.learn.learner",
    "LearnOptions": "rac.learn.options",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'rac.learn' has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name]), name)
