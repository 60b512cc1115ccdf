"""Model-comparison statistics checked against the dissertation's own numbers (§10.2.3)."""

from __future__ import annotations

import math

import pytest

from rac.evaluate.stats import (
    Summary,
    binomial_cdf_half,
    mcnemar,
    summarize,
    two_sided_p,
    z_test,
    z_test_dissertation,
)

# §10.2.3's table: which of the 12 injected faults each model diagnosed, and its μ and σ as
# printed, truncated to three decimals (8/12 is printed 0.666, sqrt(10/144) = 0.3727 is 0.372).
TABLE = {
    "M1": ([0, 0, 0, 0, 1, 1, 1, 1, 0, 0, 1, 1], 0.500, 0.500),
    "M2": ([0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1], 0.666, 0.471),
    "M3": ([0, 0, 0, 0, 1, 0, 1, 1, 1, 0, 1, 1], 0.500, 0.500),
    "M4": ([1, 1, 1, 0, 1, 1, 1, 1, 0, 0, 1, 1], 0.750, 0.433),
    "M5": ([0, 0, 0, 0, 1, 0, 1, 1, 1, 1, 1, 1], 0.583, 0.493),
    "M6": ([1, 0, 0, 0, 1, 0, 1, 1, 1, 0, 1, 1], 0.583, 0.493),
    "M7": ([1, 1, 0, 0, 1, 0, 1, 1, 1, 0, 1, 1], 0.666, 0.471),
    "M8": ([1, 1, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1], 0.916, 0.276),
    "M9": ([1, 0, 1, 1, 1, 1, 1, 1, 1, 0, 1, 1], 0.833, 0.372),
}
M3, M8 = TABLE["M3"][0], TABLE["M8"][0]


@pytest.mark.parametrize("model", sorted(TABLE))
def test_mean_and_population_sd_match_the_table(model: str) -> None:
    outcomes, mu, sigma = TABLE[model]
    s = summarize(outcomes)
    assert s.n == 12
    assert math.floor(s.mean * 1000) / 1000 == pytest.approx(mu)
    assert math.floor(s.sd * 1000) / 1000 == pytest.approx(sigma)
    # The population σ (divide by n), not the sample one (n − 1).
    assert s.sd == pytest.approx(math.sqrt(sum((x - s.mean) ** 2 for x in outcomes) / 12))


def test_printed_formula_reproduces_the_dissertations_z() -> None:
    # Eq. 10.2 with the table's rounded μ and σ: 0.416 / sqrt(0.064666) = 1.63586.
    printed = z_test_dissertation(Summary(12, 0.500, 0.500), Summary(12, 0.916, 0.276))
    assert printed.statistic == pytest.approx(1.63586, abs=1e-4)
    assert not printed.significant  # |z| < 1.96: the dissertation keeps H0
    # From the outcome vectors themselves (μ8 = 11/12 unrounded) the same formula gives 1.638.
    exact = z_test_dissertation(summarize(M3), summarize(M8))
    assert exact.statistic == pytest.approx(1.63586, abs=3e-3)
    assert exact.p == pytest.approx(0.1014, abs=1e-3)


def test_corrected_formula_makes_m3_against_m8_significant() -> None:
    corrected = z_test(summarize(M3), summarize(M8))
    # (11/12 − 1/2) / sqrt((1/4)/12 + (11/144)/12) = 2.5264; the errata's "≈ 2.52".
    expected = (11 / 12 - 0.5) / math.sqrt(0.25 / 12 + (11 / 12) * (1 / 12) / 12)
    assert corrected.statistic == pytest.approx(expected, rel=1e-12)
    assert corrected.statistic == pytest.approx(2.52, abs=0.01)
    assert corrected.p == pytest.approx(math.erfc(expected / math.sqrt(2)))
    assert corrected.p == pytest.approx(0.0115, abs=1e-3)
    assert corrected.significant
    # Swapping the models flips the sign only.
    swapped = z_test(summarize(M8), summarize(M3))
    assert swapped.statistic == pytest.approx(-expected)
    assert swapped.p == pytest.approx(corrected.p)


def test_mcnemar_on_m3_and_m8_by_hand() -> None:
    # Faults 1-4 and 10: only M8 right (c = 5); no fault only M3 got right (b = 0); fault 6
    # both missed.  p = 2 · P(Bin(5, 1/2) ≤ 0) = 2 / 32 = 0.0625: not significant at 0.05.
    result = mcnemar(M3, M8)
    assert (result.b, result.c) == (0, 5)
    assert result.p == pytest.approx(0.0625, rel=1e-12)
    assert not result.significant
    assert mcnemar(M8, M3) == type(result)(5, 0, result.p, result.alpha)


def test_mcnemar_small_cases() -> None:
    # b = 1, c = 6: 2 · (1 + 7) / 128 = 0.125.
    first = [1, 0, 0, 0, 0, 0, 0, 1]
    second = [0, 1, 1, 1, 1, 1, 1, 1]
    assert mcnemar(first, second).p == pytest.approx(0.125)
    # Balanced discordance: 2 · P(X ≤ 2 | n = 4) = 2 · 11/16 > 1, capped at 1.
    assert mcnemar([1, 1, 0, 0], [0, 0, 1, 1]).p == 1.0
    # Ten one-sided discordant pairs: 2 / 1024, significant.
    lopsided = mcnemar([0] * 10, [1] * 10)
    assert lopsided.p == pytest.approx(2 / 1024) and lopsided.significant


def test_binomial_cdf_is_exact() -> None:
    assert binomial_cdf_half(0, 5) == 1 / 32
    assert binomial_cdf_half(2, 4) == 11 / 16
    assert binomial_cdf_half(-1, 3) == 0.0
    assert binomial_cdf_half(3, 3) == 1.0
    assert binomial_cdf_half(500, 1000) == pytest.approx(0.5 + math.comb(1000, 500) / 2**1001)


def test_equal_outcomes_and_zero_spread_are_defined() -> None:
    same = summarize([1, 1, 1, 1])
    assert same == Summary(4, 1.0, 0.0)
    for test in (z_test, z_test_dissertation):
        tie = test(same, same)
        assert (tie.statistic, tie.p, tie.significant) == (0.0, 1.0, False)
        apart = test(summarize([0, 0, 0]), same)
        assert apart.statistic == math.inf and apart.p == 0.0 and apart.significant
        assert test(same, summarize([0, 0, 0])).statistic == -math.inf
    # One σ is zero, the other is not: an ordinary finite z.
    assert math.isfinite(z_test(same, summarize([1, 0, 1, 1])).statistic)
    assert mcnemar([1, 0, 1], [1, 0, 1]).p == 1.0  # no discordant pair


def test_two_sided_p_at_the_textbook_critical_value() -> None:
    assert two_sided_p(1.959964) == pytest.approx(0.05, abs=1e-6)
    assert two_sided_p(-1.959964) == two_sided_p(1.959964)
    assert two_sided_p(0.0) == 1.0


@pytest.mark.parametrize("bad", [[], [0, 2], [0.5, 1], [-1]])
def test_bad_outcomes_are_value_errors(bad: list[float]) -> None:
    with pytest.raises(ValueError):
        summarize(bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        mcnemar([0, 1], [0, 1, 1])
