"""The navigation consistency arithmetic: NEES, the χ² band of a mean, and how many independent
values a correlated series is worth."""

import numpy as np
from scipy.stats import chi2

from coopsat.analysis.papers.navigation import chi2_band, effective_count, nees


def test_nees_is_the_quadratic_form_in_the_inverse_covariance():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(5, 6, 6))
    cov = a @ np.swapaxes(a, -1, -2) + 6 * np.eye(6)
    e = rng.normal(size=(5, 6))
    expected = [e[k] @ np.linalg.inv(cov[k]) @ e[k] for k in range(5)]
    np.testing.assert_allclose(nees(e, cov), expected, rtol=1e-12)


def test_the_band_of_a_mean_is_the_chi_square_of_the_sum():
    low, high = chi2_band(6, 40)
    assert low == chi2.ppf(0.025, 240) / 40 and high == chi2.ppf(0.975, 240) / 40
    # Drawn means of 40 χ²(6) values fall inside about 95 % of the time.
    means = np.random.default_rng(3).chisquare(6, size=(4000, 40)).mean(axis=1)
    assert abs(np.mean((means >= low) & (means <= high)) - 0.95) < 0.015


def test_a_white_series_counts_every_sample_and_a_correlated_one_fewer():
    """White noise: T values. A first-order autoregression with φ = 0.9 is worth
    T (1 − φ)/(1 + φ) (its integrated autocorrelation time is (1 + φ)/(1 − φ)); a constant, T."""
    rng = np.random.default_rng(0)
    assert effective_count(rng.normal(size=5000)) == 5000.0
    phi, t = 0.9, 20000
    e = rng.normal(size=t)
    x = np.empty(t)
    x[0] = e[0]
    for k in range(1, t):
        x[k] = phi * x[k - 1] + e[k]
    expected = t * (1 - phi) / (1 + phi)
    assert abs(effective_count(x) / expected - 1.0) < 0.1
    assert effective_count(np.full(10, 3.0)) == 10.0
