"""Posterior predictive checks of the residuals (drumroll.inference.adequacy).

The statistics against plain-Python references; the p-values' calibration under a model that
is right (residuals that are the model's own noise: a check fails in about 1 % of rolls) and
their power against the pattern a wrong model leaves (residuals that drift together).
"""

from __future__ import annotations

import itertools

import numpy as np

from drumroll.inference.adequacy import (
    LEVEL,
    check_residuals,
    lag1_autocorrelation,
    scatter_walk,
    sign_runs,
)
from drumroll.inference.results import Adequacy


def _lag1_reference(r: list[float]) -> float:
    mean = sum(r) / len(r)
    c = [x - mean for x in r]
    return sum(a * b for a, b in itertools.pairwise(c)) / sum(x * x for x in c)


def _runs_reference(r: list[float]) -> int:
    return len([key for key, _ in itertools.groupby(x >= 0 for x in r)])


def test_statistics_equal_plain_python():
    rng = np.random.default_rng(0)
    residuals = rng.standard_normal((50, 17))
    residuals[3, 5] = 0.0  # a zero counts as positive
    np.testing.assert_allclose(lag1_autocorrelation(residuals),
                               [_lag1_reference(list(row)) for row in residuals], rtol=1e-12)
    assert sign_runs(residuals).tolist() == [_runs_reference(list(row)) for row in residuals]


def _ar1(rng: np.random.Generator, shape: tuple[int, ...], rho: float) -> np.ndarray:
    out = np.empty(shape)
    out[..., 0] = rng.standard_normal(shape[:-1])
    for i in range(1, shape[-1]):
        out[..., i] = rho * out[..., i - 1] + np.sqrt(1 - rho * rho) * rng.standard_normal(
            shape[:-1])
    return out


def test_a_right_model_fails_in_about_one_roll_in_fifty():
    """Rolls of 15 onsets whose residuals are the model's own noise: each check's p-value is
    uniform, so the model is flagged in at most 2 % of rolls (two checks at 1 %)."""
    rng = np.random.default_rng(1)
    rolls, draws, n = 2000, 400, 15
    flagged = 0
    for _ in range(rolls):
        observed = np.broadcast_to(rng.standard_normal(n), (draws, n))
        flagged += check_residuals(observed, rng.standard_normal((draws, n))).adequate is False
    rate = flagged / rolls
    # binomial 99 % band about 2 % for 2000 rolls: ± 0.8 %; the discrete runs make it smaller
    assert 0.003 <= rate <= 0.028, rate


def test_residuals_that_drift_together_are_flagged():
    """Residuals with lag-1 correlation 0.8 (a restitution that drifts with speed leaves such
    a wave) over 30 onsets: flagged in nearly every roll."""
    rng = np.random.default_rng(2)
    rolls, draws, n = 200, 400, 30
    observed = _ar1(rng, (rolls, n), 0.8)
    flagged = sum(check_residuals(np.broadcast_to(row, (draws, n)),
                                  rng.standard_normal((draws, n))).adequate is False
                  for row in observed)
    assert flagged / rolls >= 0.9


def test_too_short_a_roll_is_not_judged():
    result = check_residuals(np.zeros((10, 3)), np.zeros((10, 3)))
    assert result.adequate is None and result.checks == {} and result.misfit("powerlaw") is None


def test_the_misfit_names_the_failed_check_and_round_trips_through_json():
    rng = np.random.default_rng(3)
    observed = np.broadcast_to(np.linspace(-1, 1, 20) ** 2 - 0.4, (300, 20))  # a smooth wave
    result = check_residuals(observed, rng.standard_normal((300, 20)))
    assert result.adequate is False and result.level == LEVEL
    sentence = result.misfit("powerlaw")
    assert sentence.startswith("powerlaw does not describe these onsets")
    assert "p < 0.001" in sentence
    assert Adequacy.from_json(result.to_json()) == result


def _walk_reference(r, w, J, G):
    """scatter_walk written with explicit matrices: the weighted residual maker
    P = I − W^½ J (Jᵀ W J)⁻¹ Jᵀ W^½, S = W^½ G, and the two ratios to their expectations
    under white noise."""
    root = np.diag(np.sqrt(w))
    a, A, S = root @ r, root @ J, root @ G
    P = np.eye(len(r)) - A @ np.linalg.inv(A.T @ A) @ A.T
    return (float((S.T @ P @ a) @ (S.T @ P @ a)) / float(np.trace(S.T @ P @ S))
            / (float(a @ P @ a) / (len(r) - J.shape[1])))


def _walk_problem(rng, n=16, draws=5):
    """Weights, parameter directions (an offset, a trend, a curvature) and a random walk's
    sensitivity (cumulative flights) for ``draws`` draws."""
    w = 1.0 / rng.uniform(0.5e-4, 2e-4, (draws, n)) ** 2
    k = np.arange(n) / n
    J = np.stack([np.ones(n), k, k**2], axis=1)
    J = np.broadcast_to(J, (draws, n, 3)) * rng.uniform(0.5, 2.0, (draws, 1, 3))
    flights = 0.25 * 0.9 ** np.arange(n - 1)
    times = np.concatenate(([0.0], np.cumsum(flights)))
    G = np.where(np.arange(1, n)[None, :] <= np.arange(n)[:, None],
                 times[:, None] - times[None, :-1], 0.0)
    return w, J, np.broadcast_to(G, (draws, n, n - 1)).copy()


def test_scatter_walk_equals_explicit_matrices():
    rng = np.random.default_rng(4)
    w, J, G = _walk_problem(rng)
    r = rng.standard_normal(w.shape) / np.sqrt(w)
    np.testing.assert_allclose(scatter_walk(r, w, J, G),
                               [_walk_reference(r[b], w[b], J[b], G[b]) for b in range(5)],
                               rtol=1e-9)


def test_scatter_walk_ignores_what_the_parameters_can_follow():
    """Residuals plus any combination of the parameters' directions (an error in T0, in α,
    in t_B) give the same statistic: the check sees only what the fit cannot absorb; a
    direction counted twice (a stick's geometry) changes nothing either."""
    rng = np.random.default_rng(5)
    w, J, G = _walk_problem(rng)
    r = rng.standard_normal(w.shape) / np.sqrt(w)
    moved = r + np.einsum("bnp,bp->bn", J, rng.normal(0.0, 1e-3, (5, 3)))
    twice = np.concatenate([J, J[:, :, 1:2] * 3.0], axis=2)
    np.testing.assert_allclose(scatter_walk(moved, w, J, G), scatter_walk(r, w, J, G),
                               rtol=1e-6)
    np.testing.assert_allclose(scatter_walk(r, w, twice, G), scatter_walk(r, w, J, G),
                               rtol=1e-6)


def test_scatter_walk_is_one_for_white_noise_and_grows_with_a_scatter():
    """Its two parts are each 1 in expectation for independent noise; onsets moved by a
    scattering restitution (G ε, ε ~ N(0, s²)) put several times more in those directions."""
    rng = np.random.default_rng(6)
    w, J, G = _walk_problem(rng, draws=4000)
    white = rng.standard_normal(w.shape) / np.sqrt(w)
    assert 0.9 < np.median(scatter_walk(white, w, J, G)) / np.median(
        scatter_walk(rng.standard_normal(w.shape) / np.sqrt(w), w, J, G)) < 1.1
    assert 0.9 < np.mean(scatter_walk(white, w, J, G)) < 1.2
    walked = white + np.einsum("bnk,bk->bn", G, rng.normal(0.0, 0.002, G.shape[::2]))
    assert np.median(scatter_walk(walked, w, J, G)) > 3.0
