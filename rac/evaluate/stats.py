"""Statistics for comparing diagnosis models (§3.6, §10.2.3): pure functions, no I/O.

Each model's outcome over the injected faults is a 0/1 vector (1: the fault was diagnosed
correctly).  :func:`summarize` gives its mean and population standard deviation, the μ and
σ of §10.2.3's table.  Two models are compared three ways:

- :func:`z_test_dissertation`: Equations 3.5 and 10.1 as printed, with the standard
  deviations (not the variances) under the root.  It reproduces the dissertation's
  z = 1.64 for M3 against M8; it is kept for that comparison only.
- :func:`z_test`: the standard two-sample z statistic the errata gives,
  z = (μ₂ − μ₁) / sqrt(σ₁²/n₁ + σ₂²/n₂).
- :func:`mcnemar`: McNemar's exact test.  Every model sees the same faults, so the
  outcomes are paired; this test uses the pairing and needs no normal approximation,
  which a dozen 0/1 samples do not justify.

Degenerate cases are defined rather than raised: when both spreads are zero (every
outcome of each model equal) the z statistic is 0 if the means agree (no evidence of a
difference, p = 1) and ±infinity if they differ (p = 0).  McNemar with no discordant
pair gives p = 1.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

ALPHA = 0.05  # §3.6: the common significance level, |z| > 1.96


@dataclass(frozen=True, slots=True)
class Summary:
    """n outcomes, their mean μ and population standard deviation σ (divided by n)."""

    n: int
    mean: float
    sd: float


@dataclass(frozen=True, slots=True)
class Test:
    """A two-sided test: its statistic, p-value and verdict at ``alpha`` (p ≤ α)."""

    statistic: float
    p: float
    alpha: float

    @property
    def significant(self) -> bool:
        return self.p <= self.alpha


@dataclass(frozen=True, slots=True)
class McNemar:
    """Discordant pairs: ``b`` where only the first model was right, ``c`` only the second."""

    b: int
    c: int
    p: float
    alpha: float

    @property
    def significant(self) -> bool:
        return self.p <= self.alpha


def _outcomes(values: Sequence[int | bool], what: str) -> list[int]:
    out = [int(v) for v in values]
    if not out:
        raise ValueError(f"{what}: no outcomes")
    if any(v not in (0, 1) or v != values[i] for i, v in enumerate(out)):
        raise ValueError(f"{what}: outcomes must be 0 or 1")
    return out


def summarize(outcomes: Sequence[int | bool]) -> Summary:
    """μ and population σ of a non-empty 0/1 vector (ValueError otherwise)."""
    values = _outcomes(outcomes, "summarize")
    n = len(values)
    mean = sum(values) / n
    # For 0/1 outcomes the population variance is μ(1 − μ); clamp rounding below zero.
    return Summary(n, mean, math.sqrt(max(0.0, mean * (1.0 - mean))))


def two_sided_p(z: float) -> float:
    """P(|Z| ≥ |z|) for a standard normal Z."""
    return math.erfc(abs(z) / math.sqrt(2.0))


def _z(difference: float, spread: float, alpha: float) -> Test:
    if spread > 0.0:
        z = difference / math.sqrt(spread)
    else:  # both σ are 0: the outcomes are constant, so the means differ surely or not at all
        z = 0.0 if difference == 0.0 else math.copysign(math.inf, difference)
    return Test(z, two_sided_p(z), alpha)


def z_test(first: Summary, second: Summary, alpha: float = ALPHA) -> Test:
    """The errata's z = (μ₂ − μ₁) / sqrt(σ₁²/n₁ + σ₂²/n₂), positive when ``second`` is better."""
    spread = first.sd**2 / first.n + second.sd**2 / second.n
    return _z(second.mean - first.mean, spread, alpha)


def z_test_dissertation(first: Summary, second: Summary, alpha: float = ALPHA) -> Test:
    """Equation 10.1 as printed: z = (μ₂ − μ₁) / sqrt(σ₁/n₁ + σ₂/n₂) (σ, not σ²)."""
    spread = first.sd / first.n + second.sd / second.n
    return _z(second.mean - first.mean, spread, alpha)


def binomial_cdf_half(k: int, n: int) -> float:
    """P(X ≤ k) for X ~ Bin(n, 1/2), exactly (integer arithmetic, one rounding)."""
    if k < 0:
        return 0.0
    if k >= n:
        return 1.0
    return sum(math.comb(n, i) for i in range(k + 1)) / (1 << n)


def mcnemar(
    first: Sequence[int | bool], second: Sequence[int | bool], alpha: float = ALPHA
) -> McNemar:
    """McNemar's exact test on paired 0/1 outcomes (the same faults, two models).

    A two-sided binomial test on the discordant pairs: p = min(1, 2·P(X ≤ min(b, c))) with
    X ~ Bin(b + c, 1/2); no discordant pair gives p = 1.
    """
    a, b_ = _outcomes(first, "mcnemar"), _outcomes(second, "mcnemar")
    if len(a) != len(b_):
        raise ValueError(f"mcnemar: {len(a)} and {len(b_)} outcomes are not paired")
    b = sum(1 for x, y in zip(a, b_, strict=True) if x == 1 and y == 0)
    c = sum(1 for x, y in zip(a, b_, strict=True) if x == 0 and y == 1)
    p = 1.0 if b + c == 0 else min(1.0, 2.0 * binomial_cdf_half(min(b, c), b + c))
    return McNemar(b, c, p, alpha)
