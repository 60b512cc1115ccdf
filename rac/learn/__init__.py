"""``racc learn``: learn a model from recorded fault-free runs (chapter 9)."""

from rac.learn.learner import LearnResult, learn, observer_counts, report
from rac.learn.options import LearnOptions

__all__ = ["LearnOptions", "LearnResult", "learn", "observer_counts", "report"]
