"""The learning parameters (Algorithms 15-17) and their defaults."""

from __future__ import annotations

from dataclasses import dataclass

DEFAULT_ALPHA = 2.5  # M8 of Table 10.1, the best model of §10.2.2
DEFAULT_Q = 0.5
DEFAULT_OCCURRENCES = 10  # C: occurrences per regression window (also ω = c/freq, Eq. 5.3)
DEFAULT_SIGMAS = 3.0
DEFAULT_MIN_LIFT = 0.05
DEFAULT_BLOCKS = 4  # time blocks of one training run for held-out validation
DEFAULT_SIGNIFICANCE = 0.05  # family-wise error rate (Holm) of the held-out tests
DEFAULT_PER_EDGE = 1  # relations kept per graph edge (a node's input and output)


@dataclass(frozen=True, slots=True)
class LearnOptions:
    alpha: float = DEFAULT_ALPHA  # a topic is regular when mean(Δ)/σ(Δ) > α
    q: float = DEFAULT_Q  # two signals are related when their match ratio > Q
    occurrences: int = DEFAULT_OCCURRENCES  # C
    min_lift: float = DEFAULT_MIN_LIFT  # and their ratio beats chance by this much (0: off)
    sigmas: float = DEFAULT_SIGMAS  # property limit = mean + k·σ (at least the largest sample)
    integrate: bool = True  # also correlate integrated signals I(M) (Algorithm 16)
    validate: bool = True  # drop observers that report a fault on the training runs
    blocks: int = DEFAULT_BLOCKS  # held-out validation over blocks (0: none)
    significance: float = DEFAULT_SIGNIFICANCE  # Holm's family-wise error rate
    name: str | None = None  # the robot's name when there is no base model
    include: tuple[str, ...] = ()  # keep these racc/tool nodes and topics (globs)
    exclude: tuple[str, ...] = ()  # leave these topics out (globs)
    blind: bool = False  # also try the pairs neither the graph nor the types explain
    per_edge: int = DEFAULT_PER_EDGE  # relations kept per graph edge (0: all)
