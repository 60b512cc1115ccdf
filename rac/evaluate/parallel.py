"""The parallel map of ``racc evaluate`` (it lives in :mod:`rac.parallel`, which reading and
learning share)."""

from rac.parallel import default_jobs, run_all

__all__ = ["default_jobs", "run_all"]
