"""A restitution that scatters from bounce to bounce: onsets with a dense covariance.

No real impact repeats exactly: α_k = α(v_k) e^{ε_k}, ε_k ~ N(0, s²) independently for every
bounce (``restitution_scatter`` s under ``[priors]``). Flight k depends on the restitutions only
through u_k = Σ_{j≤k} ln α_j (:meth:`~drumroll.physics.model.ForwardModel.restitution_slopes`),
and ε_j moves u_k (k ≥ j) by D_kj ε_j: D_kj = 1 for a constant restitution (eq. 9), and
D_kj = P_k / P_j under a law whose α depends on the impact speed, P_k = Π_{i≤k} ∂u_i/∂u_{i−1}
(:meth:`~drumroll.physics.restitution.RestitutionLaw.propagation`: a bounce sent off faster
hits harder next time and loses more). To first order in the ε the impact times move by

    δτ_m = Σ_{j≤m} G_mj ε_j,    G_mj = Σ_{k=j}^{m} ∂T_k/∂u_k D_kj = (C_m − C_{j−1}) / P_j,

C the running sums of slope_k P_k (C_0 = 0). A scatter once in a roll moves every later impact:
the onsets' errors are a random walk on top of the independent timing noise. The ε are
marginalised analytically, not sampled: the onsets t_i = T0 + τ_{k_i} + e_i are Gaussian with
covariance

    Σ = diag(σ² + s_i²) + s² G Gᵀ   (rows at the observed bounce numbers k_i),

and T0, under its flat prior, is integrated out as in :func:`~.likelihood.gaussian_marginal`
(which this equals when s = 0). The linearisation's error, against drawing the ε and running
the exact flights, is measured in tests/unit/inference/test_scatter.py.

One bordered Cholesky factor per parameter point gives everything: the factor of
M = [[Σ, B], [Bᵀ, c I]] with B = [r, 1] holds L (Σ = L Lᵀ) and, below it, the rows
L₂₁ = Bᵀ L⁻ᵀ, whose products are r'Σ⁻¹r, 1'Σ⁻¹r and 1'Σ⁻¹1: one LAPACK call for a whole batch
of walkers, with no triangular solves. ``c`` only has to make M positive definite.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from drumroll.inference.likelihood import OnsetData, t0_marginal

_LOG_2PI = math.log(2.0 * math.pi)


def impact_sensitivity(data: OnsetData, slopes: NDArray, propagation: NDArray | None = None
                       ) -> NDArray:
    """G: ∂τ_{k_i}/∂ε_j for every observed onset i and bounce j = 1 … K.

    Parameters
    ----------
    data
        The onsets (their bounce numbers k_i; K the last).
    slopes
        ∂T_k/∂u_k of flights k = 1 … K, shape ``(batch, K)``.
    propagation
        ∂u_k/∂u_{k−1}, shape ``(batch, K)``, or None where it is 1 (a constant restitution).

    Returns
    -------
    NDArray
        Shape ``(batch, n_onsets, K)``; zero where j > k_i (a bounce cannot move the impacts
        before it).
    """
    running = np.zeros((slopes.shape[0], slopes.shape[1] + 1))
    carried = None if propagation is None else np.cumprod(propagation, axis=1)  # P_1 … P_K
    np.cumsum(slopes if carried is None else slopes * carried, axis=1,
              out=running[:, 1:])  # C_0 … C_K
    at = data.bounces
    # C_{k_i} − C_{j−1} for j ≤ k_i, zero beyond (masked in place: one array per call).
    sensitivity = running[:, at, None] - running[:, None, :-1]
    sensitivity *= np.arange(1, slopes.shape[1] + 1)[None, :] <= at[:, None]
    if carried is not None:
        sensitivity /= carried[:, None, :]
    return sensitivity


def onset_covariance(data: OnsetData, slopes: NDArray, jitter: NDArray, scatter: NDArray,
                     propagation: NDArray | None = None) -> NDArray:
    """Σ = diag(σ² + s_i²) + s² G Gᵀ, shape ``(batch, n_onsets, n_onsets)`` (module docstring).

    Parameters
    ----------
    data
        The onsets.
    slopes
        ∂T_k/∂u_k, shape ``(batch, K)``.
    jitter, scatter
        σ (s) and s (sd of ln α_k) per row, shape ``(batch,)`` (or scalars).
    propagation
        The restitution law's ∂u_k/∂u_{k−1}, ``(batch, K)``; None for a constant α.
    """
    sensitivity = impact_sensitivity(data, slopes, propagation)
    scatter2 = np.reshape(np.asarray(scatter, float) ** 2, (-1, 1, 1))
    covariance = scatter2 * np.matmul(sensitivity, sensitivity.transpose(0, 2, 1))
    diagonal = np.reshape(np.asarray(jitter, float) ** 2, (-1, 1)) + data.sigmas**2
    i = np.arange(data.n_onsets)
    covariance[:, i, i] += diagonal
    return covariance


def _bordered(data: OnsetData, impacts: NDArray, covariance: NDArray
              ) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
    """r'Σ⁻¹r, 1'Σ⁻¹r, 1'Σ⁻¹1 and log|Σ| per row, for residuals r centred on their mean
    (T0 is flat, so the shift changes nothing but the round-off), and that mean."""
    residual = data.times - data.at_onsets(impacts)
    centre = residual.mean(axis=1)
    residual = residual - centre[:, None]
    batch, n = residual.shape
    border = np.stack([residual, np.ones_like(residual)], axis=2)  # B, (batch, n, 2)
    # λ_min(Σ) ≥ min of its diagonal noise, so c > tr(BᵀB) / that bounds BᵀΣ⁻¹B from above.
    floor = np.min(np.diagonal(covariance, axis1=1, axis2=2), axis=1)
    c = 2.0 * (np.einsum("bij,bij->b", border, border) + 1.0) / floor
    bordered = np.empty((batch, n + 2, n + 2))
    bordered[:, :n, :n] = covariance
    bordered[:, :n, n:] = border
    bordered[:, n:, :n] = border.transpose(0, 2, 1)
    bordered[:, n:, n:] = c[:, None, None] * np.eye(2)
    factor = np.linalg.cholesky(bordered)
    below = factor[:, n:, :n]  # L₂₁ = Bᵀ L⁻ᵀ
    q_rr = np.einsum("bi,bi->b", below[:, 0], below[:, 0])
    q_r1 = np.einsum("bi,bi->b", below[:, 0], below[:, 1])
    q_11 = np.einsum("bi,bi->b", below[:, 1], below[:, 1])
    log_det = 2.0 * np.log(np.diagonal(factor[:, :n, :n], axis1=1, axis2=2)).sum(axis=1)
    return q_rr, q_r1, q_11, log_det, centre


def scatter_marginal(data: OnsetData, impacts: NDArray, covariance: NDArray
                     ) -> tuple[NDArray, NDArray, NDArray]:
    """Log-likelihood with the ε and T0 marginalised, and T0's conditional mean and sd.

    Parameters
    ----------
    data
        The onsets.
    impacts
        τ_0 … τ_K, shape ``(batch, K + 1)``.
    covariance
        Σ from :func:`onset_covariance`, ``(batch, n_onsets, n_onsets)``.

    Returns
    -------
    log_like, t0_mean, t0_sd
        Shape ``(batch,)``; ``log_like`` is −inf where a row is not finite or Σ is not
        positive definite.
    """
    batch = impacts.shape[0]
    log_like = np.full(batch, -np.inf)
    t0_mean = np.full(batch, np.nan)
    t0_sd = np.full(batch, np.nan)
    good = np.flatnonzero(np.isfinite(impacts).all(axis=1)
                          & np.isfinite(covariance).all(axis=(1, 2)))
    try:
        parts = [(good, _bordered(data, impacts[good], covariance[good]))] if good.size else []
    except np.linalg.LinAlgError:  # a row whose Σ is not positive definite: one by one
        parts = []
        for row in good:
            try:
                # The rows as an index array (a scalar index would take a length-1 result
                # as one element: a ValueError).
                parts.append((np.array([row]), _bordered(data, impacts[row:row + 1],
                                                         covariance[row:row + 1])))
            except np.linalg.LinAlgError:
                continue
    n = data.n_onsets
    for rows, (q_rr, q_r1, q_11, log_det, centre) in parts:
        log_like[rows] = t0_marginal(q_rr - q_r1**2 / q_11, log_det, q_11, n)
        t0_mean[rows] = centre + q_r1 / q_11
        t0_sd[rows] = 1.0 / np.sqrt(q_11)
    return np.where(np.isfinite(log_like), log_like, -np.inf), t0_mean, t0_sd


def scatter_conditional_pointwise(data: OnsetData, impacts: NDArray, covariance: NDArray
                                  ) -> NDArray:
    """log p(t_i | t_{−i}, θ) per row and onset, shape ``(batch, n_onsets)``: the terms
    PSIS-LOO needs for a non-factorised Gaussian (Bürkner, Gabry & Vehtari 2021).

    With T0 flat and integrated out, the residuals r have the (improper) precision
    P = Σ⁻¹ − Σ⁻¹11ᵀΣ⁻¹ / (1ᵀΣ⁻¹1), and the conditional of r_i given the others is
    N(r_i − (P r)_i / P_ii, 1 / P_ii); with Σ diagonal this is
    :func:`~drumroll.inference.loo.conditional_pointwise`.
    """
    residual = data.times - data.at_onsets(impacts)
    precision = np.linalg.inv(covariance)
    column = precision.sum(axis=2)  # Σ⁻¹1
    total = column.sum(axis=1)  # 1ᵀΣ⁻¹1
    projected = precision - column[:, :, None] * column[:, None, :] / total[:, None, None]
    p_r = np.einsum("bij,bj->bi", projected, residual)
    p_ii = np.diagonal(projected, axis1=1, axis2=2)
    return 0.5 * (np.log(p_ii) - _LOG_2PI) - 0.5 * p_r**2 / p_ii


def scatter_noise(covariance: NDArray, rng: np.random.Generator) -> NDArray:
    """One draw of the onsets' noise per row, N(0, Σ), shape ``(batch, n_onsets)``."""
    factor = np.linalg.cholesky(covariance)
    return np.einsum("bij,bj->bi", factor, rng.standard_normal(covariance.shape[:2]))
