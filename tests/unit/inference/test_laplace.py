"""Laplace's method against exact integrals: a correlated Gaussian, a Gaussian cut by a
bound (quadrature), a density with no peak."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from drumroll.inference.laplace import laplace

COVARIANCE = np.array([[2.0, 0.6, -0.3], [0.6, 1.0, 0.2], [-0.3, 0.2, 0.5]])


def _gaussian(log_scale: float, mean: np.ndarray, covariance: np.ndarray):
    distribution = stats.multivariate_normal(mean, covariance)
    return lambda z: log_scale + distribution.logpdf(np.atleast_2d(z)).reshape(-1)


def test_laplace_is_exact_for_a_gaussian():
    density = _gaussian(3.7, np.array([1.0, -2.0, 0.5]), COVARIANCE)
    box = np.array([[-np.inf, np.inf]] * 3)
    estimate = laplace(density, np.array([1.0, -2.0, 0.5]), box)
    assert estimate.log_z == pytest.approx(3.7, abs=1e-5)
    assert estimate.covariance == pytest.approx(COVARIANCE, rel=1e-3)


@pytest.mark.parametrize("mean", [-1.5, 0.0, 0.7])
def test_laplace_integrates_one_side_of_a_bound(mean):
    """A 2-d Gaussian cut at x ≥ 0: the mode on the bound (mean ≤ 0) integrates the one side;
    the integral is checked against quadrature of the same density."""
    covariance = np.array([[0.4, 0.0], [0.0, 1.3]])
    density = _gaussian(0.0, np.array([mean, 0.0]), covariance)
    box = np.array([[0.0, 10.0], [-np.inf, np.inf]])
    mode = np.array([max(mean, 0.0), 0.0])
    exact = math.log(integrate.dblquad(lambda y, x: math.exp(density([x, y])[0]),
                                       0.0, 10.0, -12.0, 12.0)[0])
    expected = exact if mean <= 0.0 else 0.0  # a mode inside: the whole Gaussian
    tolerance = 0.02 if mean > 0 else 1e-3
    assert laplace(density, mode, box).log_z == pytest.approx(expected, abs=tolerance)


def test_laplace_has_no_answer_where_the_density_is_not_peaked():
    flat = lambda z: np.zeros(np.atleast_2d(z).shape[0])  # noqa: E731
    assert math.isnan(laplace(flat, np.zeros(2), np.array([[-np.inf, np.inf]] * 2)).log_z)
