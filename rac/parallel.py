"""Independent work items over the machine's cores: reading and summarising recordings,
learning the models of a grid, replaying every model over every run.

Workers are forked, so they inherit what the parent loaded (recordings, event streams)
without copying it through pipes; only the items and the results travel.  Where fork is
not available, or one job is asked for, the items run one after another in this process.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any, TypeVar

T = TypeVar("T")
R = TypeVar("R")

_TASK: list[Callable[[Any], Any]] = []  # the function the forked workers call


def default_jobs() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def _call(item: Any) -> Any:
    return _TASK[0](item)


def mapper(jobs: int) -> Callable[[Callable[[Any], Any], Sequence[Any]], list[Any]]:
    """``run_all`` with ``jobs`` fixed: how an engine is given the machine's cores."""

    def spread(fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
        return run_all(fn, items, jobs)

    return spread


def run_all(fn: Callable[[T], R], items: Sequence[T], jobs: int) -> list[R]:
    """``[fn(i) for i in items]``, in order, on up to ``jobs`` forked workers.  A worker
    does not fork again: work mapped from inside a worker runs there, one item after
    another (a grid of models learned in parallel summarises each one's runs serially)."""
    jobs = min(jobs, len(items))
    if jobs <= 1 or _TASK or "fork" not in multiprocessing.get_all_start_methods():
        return [fn(i) for i in items]
    _TASK[:] = [fn]
    try:
        context = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(max_workers=jobs, mp_context=context) as pool:
            return list(pool.map(_call, items))
    finally:
        _TASK.clear()
