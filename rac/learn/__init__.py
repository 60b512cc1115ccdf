"""``racc learn``: learn a model from recorded fault-free runs (chapter 9).

The names below load on first use (see :mod:`rac.lazy`): the command line imports the
light ``rac.learn.options`` at start-up without paying for NumPy and rosbags.
"""

from rac.lazy import lazy_exports

_EXPORTS = {
    "LearnResult": "rac.learn.learner",
    "learn": "rac.learn.learner",
    "observer_counts": "rac.learn.learner",
    "report": "rac.learn.learner",
    "LearnOptions": "rac.learn.options",
}

__all__ = sorted(_EXPORTS)
__getattr__ = lazy_exports(__name__, _EXPORTS)
