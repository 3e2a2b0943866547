"""IQM and its stratified bootstrap interval on data with a known answer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.leaderboard.stats import iqm, iqm_interval


def test_iqm_is_the_mean_of_the_middle_half():
    assert float(iqm(np.arange(1.0, 9.0))) == 4.5  # (3 + 4 + 5 + 6) / 4
    assert float(iqm(np.array([0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 100.0]))) == 1.0


def test_interval_of_normal_data_has_the_asymptotic_width():
    """For N(0, 1) the 25 % trimmed mean has asymptotic variance σ²/n·(∫_{−c}^{c} x²φ dx +
    2·0.25·c²)/0.5², c = Φ⁻¹(0.75): about 1.195/n."""
    from scipy.stats import norm

    c = norm.ppf(0.75)
    inner = (2 * norm.cdf(c) - 1) - 2 * c * norm.pdf(c)
    var = (inner + 0.5 * c**2) / 0.25
    n = 4000
    x = np.random.default_rng(3).normal(0.0, 1.0, n)
    ci = iqm_interval([x], seed=1)
    expected = 2 * norm.ppf(0.975) * math.sqrt(var / n)
    assert ci.low < 0.0 < ci.high
    assert ci.high - ci.low == pytest.approx(expected, rel=0.15)
    assert ci.n == n


def test_stratification_keeps_the_strata_sizes():
    """Each stratum constant: every stratified resample is the same data, so the interval has
    zero width (a plain bootstrap over the pooled values would not)."""
    ci = iqm_interval([[1.0, 1.0, 1.0], [5.0, 5.0, 5.0]])
    assert (ci.iqm, ci.low, ci.high) == (3.0, 3.0, 3.0)


def test_interval_is_reproducible_and_refuses_bad_values():
    data = [np.random.default_rng(0).normal(size=20), np.random.default_rng(1).normal(size=7)]
    assert iqm_interval(data, seed=5) == iqm_interval(data, seed=5)
    with pytest.raises(ValueError, match="finite"):
        iqm_interval([[1.0, np.nan]])
    with pytest.raises(ValueError, match="at least one"):
        iqm_interval([])
