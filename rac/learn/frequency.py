"""Frequency observers (Algorithm 15, lines 5-10): which topics are regular, and how regular."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rac.learn.recording import TopicData


@dataclass(frozen=True, slots=True)
class RateStats:
    """Inter-arrival statistics of one topic."""

    topic: str
    samples: int  # intervals measured
    mean: float  # Δ̄, seconds
    stddev: float  # σ, seconds
    regular: bool  # Δ̄/σ > α

    @property
    def ratio(self) -> float:
        return self.mean / self.stddev if self.stddev > 0 else float("inf")

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.mean

    @property
    def tolerance_hz(self) -> float:
        """The rate band whose slower edge is one σ longer than Δ̄.

        The frequency observer accepts a window mean interval within δ ± σ (Algorithm 1);
        the compiler turns a tolerance T back into that σ as 1/(rate - T) - 1/rate.
        """
        return self.rate_hz - 1.0 / (self.mean + self.stddev)


def rate_stats(topic: TopicData, alpha: float) -> RateStats | None:
    """None when the topic has fewer than three intervals (nothing to judge)."""
    deltas = topic.intervals()
    if deltas.size < 3:
        return None
    mean = float(np.mean(deltas))
    stddev = float(np.std(deltas))
    if mean <= 0:
        return RateStats(topic.name, int(deltas.size), mean, stddev, False)
    regular = stddev == 0 or mean / stddev > alpha
    return RateStats(topic.name, int(deltas.size), mean, stddev, regular)
