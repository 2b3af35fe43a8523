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

Under Gaussian noise Σ is never formed: the walk is a Markov chain from bounce to bounce, and
a Kalman filter along the roll (:func:`scatter_marginal`) gives r'Σ⁻¹r, 1'Σ⁻¹r, 1'Σ⁻¹1 and
log|Σ| from its innovations, exactly, in O(K) per parameter point; one pass back along the
roll adds Σ⁻¹r, Σ⁻¹1 and Σ⁻¹'s diagonal, LOO's terms (:func:`scatter_pointwise`), and the
replicated onsets are the walk drawn bounce by bounce (:func:`scatter_noise`). Σ itself
(:func:`onset_covariance`) serves the Student-t case below and the tests' dense references.

Under Student-t onset noise the ε cannot be integrated out in closed form: the onsets are
t_i = T0 + τ_{k_i} + (G ε)_i + e_i with e_i ~ t_ν(0, σ_i) independent. Writing ε = s z,
z ~ N(0, I), and A = s G, the likelihood is

    p(t | θ) = ∫∫ Π_i t_ν(r_i − T0 − (A z)_i) N(z; 0, I) dz dT0 / W

(r the onsets less the noise-free impacts, W T0's flat window), taken by Laplace's method
over T0 and the z together (:func:`student_t_laplace`). T0 is integrated out, not sampled, as
in the Gaussian case: sampled, it could sit on a first onset that no ε moves while the ε place
every later onset, and the likelihood would grow as 1/σ without bound as the jitter σ → 0.
The mode solves y = ψ(u), 1ᵀy = 0 (u = r − T0 − S y the residuals left, ψ = −∂ ln t_ν/∂u,
z* = Aᵀ y), found by Newton's method on the bordered system [[D⁻¹ + S, 1], [1ᵀ, 0]]; then,
with D_i the curvature −∂² ln t_ν(u_i) at the mode (floored about and past the t's
inflection, where an outlying onset adds little or none) and M = I + D^½ S D^½,

    ln p ≈ Σ_i ln t_ν(u_i) − ½ |z*|² − ½ ln det M − ½ ln(1ᵀ D^½ M⁻¹ D^½ 1) + ½ ln 2π − ln W,

the last log the precision of T0 (whose mode and sd are returned: T0's conditional draws
for the outputs), plus the expansion's next order in the t's third and fourth derivatives
(bounded by what it can correct: far from the data the series means nothing).
All of it is computed in the onsets' n × n space through S = A Aᵀ = s² G Gᵀ, so gaps (K > n)
cost nothing. It is exact as ν → ∞ (the normal of :func:`scatter_marginal`); elsewhere
its error, against importance sampling over T0 and the z and against quadrature over T0
without scatter, is measured in tests/unit/inference/test_scatter.py. LOO's terms are
ln p(t) − ln p(t_{−i}), the second the same approximation without onset i (the scatter's walk
passes through a missing onset unchanged).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drumroll.inference.likelihood import T0_WINDOW_S, OnsetData, t0_marginal
from drumroll.stats import student_t_logpdf

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


def dense_marginal(data: OnsetData, impacts: NDArray, covariance: NDArray
                   ) -> tuple[NDArray, NDArray, NDArray]:
    """:func:`scatter_marginal` from Σ itself, by dense solves: the definition the filter is
    tested against (:meth:`~drumroll.inference.posterior.LogPosterior.reference`), for any
    positive-definite ``covariance`` ``(batch, n, n)``; −inf (and NaN) where it is not."""
    residual = data.times - data.at_onsets(impacts)
    centre = residual.mean(axis=1)  # T0 is flat: centring only spares the round-off
    batch, n = residual.shape
    right = np.stack([residual - centre[:, None], np.ones_like(residual)], axis=2)
    out = np.full((3, batch), np.nan)
    out[0] = -np.inf
    for row in range(batch):
        sign, log_det = np.linalg.slogdet(covariance[row])
        if not (sign > 0 and np.isfinite(right[row]).all()):
            continue
        (q_rr, q_r1), (_, q_11) = right[row].T @ np.linalg.solve(covariance[row], right[row])
        out[:, row] = (t0_marginal(q_rr - q_r1**2 / q_11, log_det, q_11, n),
                       centre[row] + q_r1 / q_11, 1.0 / math.sqrt(q_11))
    return out[0], out[1], out[2]


@dataclass(frozen=True)
class _Filtered:
    """A Kalman filter's pass along a roll (:func:`_filter`), per row of a batch: the
    Gaussian's quadratic forms and log|Σ|, and, kept for the backward pass of
    :func:`scatter_pointwise`, each onset's innovation variance F_i, innovations ν_i of the
    residuals and of the vector of ones, filter gain M_i = P_i Zᵀ / F_i (its w and d parts),
    and the state's transition Φ_i from onset i's bounce to the next onset's (its w→w and
    w→d entries; Φ is lower triangular with 1 for d→d)."""

    q_rr: NDArray
    q_r1: NDArray
    q_11: NDArray
    log_det: NDArray
    centre: NDArray
    variance: NDArray | None = None  # (n, batch)
    innovation: NDArray | None = None  # (n, 2, batch)
    gain: NDArray | None = None  # (n, 2, batch): M_w, M_d
    transition: NDArray | None = None  # (n, 2, batch): Φ_ww, Φ_dw to the next onset


def _filter(data: OnsetData, impacts: NDArray, slopes: NDArray, jitter: NDArray,
            scatter: NDArray, propagation: NDArray | None, keep: bool = False) -> _Filtered:
    """The Kalman filter of :func:`scatter_marginal` (its docstring), keeping each onset's
    quantities for a backward pass when ``keep``."""
    batch, n = impacts.shape[0], data.n_onsets
    residual = data.times - data.at_onsets(impacts)
    centre = residual.mean(axis=1)  # T0 is flat: centring only spares the round-off
    observed = np.stack([residual - centre[:, None], np.ones_like(residual)])  # (2, batch, n)
    noise = np.asarray(jitter, float)[:, None] ** 2 + data.sigmas**2
    s2 = np.asarray(scatter, float) ** 2
    onset_at = np.full(data.n_flights + 1, -1)
    onset_at[data.bounces] = np.arange(n)
    mean_w, mean_d = np.zeros((2, batch)), np.zeros((2, batch))  # for r, and for 1
    p_ww, p_wd, p_dd = np.zeros(batch), np.zeros(batch), np.zeros(batch)
    q_rr, q_r1, q_11 = np.zeros(batch), np.zeros(batch), np.zeros(batch)  # r'Σ⁻¹r, …
    variances, innovations, gains, transitions = [], [], [], []
    phi_ww, phi_dw = np.ones(batch), np.zeros(batch)  # Φ since the last onset
    with np.errstate(divide="ignore", invalid="ignore"):  # a row without variance: −inf
        for k in range(data.n_flights + 1):
            if k:
                slope = slopes[:, k - 1]
                if propagation is None:
                    mean_d = mean_d + slope * mean_w
                    p_dd = p_dd + slope * (2.0 * p_wd + slope * p_ww) + s2 * slope * slope
                    p_wd = p_wd + slope * p_ww + s2 * slope
                    p_ww = p_ww + s2
                    if keep:
                        phi_dw = phi_dw + slope * phi_ww
                else:
                    a = propagation[:, k - 1]
                    b = slope * a
                    mean_d = mean_d + b * mean_w
                    mean_w = a * mean_w
                    p_dd = p_dd + b * (2.0 * p_wd + b * p_ww) + s2 * slope * slope
                    p_wd = a * (p_wd + b * p_ww) + s2 * slope
                    p_ww = a * a * p_ww + s2
                    if keep:
                        phi_dw = phi_dw + b * phi_ww
                        phi_ww = a * phi_ww
            i = onset_at[k]
            if i < 0:
                continue
            if keep:
                if i:  # Φ_{i−1}: from the last onset's bounce to this one's
                    transitions.append((phi_ww, phi_dw))
                phi_ww, phi_dw = np.ones(batch), np.zeros(batch)
            f = p_dd + noise[:, i]
            innovation = observed[:, :, i] - mean_d
            weighted = innovation / f
            q_rr += innovation[0] * weighted[0]
            q_r1 += innovation[0] * weighted[1]
            q_11 += innovation[1] * weighted[1]
            variances.append(f)
            if keep:
                innovations.append(innovation)
                gains.append((p_wd / f, p_dd / f))
            mean_w = mean_w + p_wd * weighted
            mean_d = mean_d + p_dd * weighted
            share = noise[:, i] / f
            p_ww = p_ww - p_wd * p_wd / f
            p_wd = p_wd * share
            p_dd = p_dd * share
        log_det = np.log(np.stack(variances)).sum(axis=0)
    if not keep:
        return _Filtered(q_rr, q_r1, q_11, log_det, centre)
    transitions.append((np.ones(batch), np.zeros(batch)))  # past the last onset: unused
    return _Filtered(q_rr, q_r1, q_11, log_det, centre, np.stack(variances),
                     np.stack(innovations), np.array(gains), np.array(transitions))


def scatter_marginal(data: OnsetData, impacts: NDArray, slopes: NDArray, jitter: NDArray,
                     scatter: NDArray, propagation: NDArray | None = None
                     ) -> tuple[NDArray, NDArray, NDArray]:
    """Log-likelihood with the ε and T0 marginalised, and T0's conditional mean and sd:
    the Gaussian of Σ (:func:`onset_covariance`) without forming Σ, by a Kalman filter along
    the roll, O(K) per row where a Cholesky factor of Σ costs O(n³) (at 55 onsets and 64
    walkers a third of the time; at a start search's 10,000 points a thirtieth).

    The scatter's effect is a Markov chain from bounce to bounce. With w_k the change of
    u_k = Σ_{j≤k} ln α_j and d_k that of impact k's time (w_0 = d_0 = 0),

        w_k = p_k w_{k−1} + ε_k,    d_k = d_{k−1} + slope_k w_k,

    p_k the restitution law's propagation ∂u_k/∂u_{k−1} (1 for a constant α), which is
    G's D_kj = P_k / P_j written one bounce at a time; each onset observes T0 + d_{k_i} with
    noise of variance σ² + s_i². The filter's innovations are those of the Cholesky factor
    of Σ (Σ = L F Lᵀ, L unit lower triangular): filtering the residuals r and the vector of
    ones side by side (the gains depend on neither) gives L⁻¹r and L⁻¹1, hence r'Σ⁻¹r,
    1'Σ⁻¹r, 1'Σ⁻¹1, and log|Σ| = Σ log F_i: T0, flat, is integrated out exactly as there.
    A bounce with no onset is predicted over, not observed.

    Parameters
    ----------
    data
        The onsets.
    impacts
        τ_0 … τ_K, ``(batch, K + 1)``.
    slopes, propagation
        ∂T_k/∂u_k and ∂u_k/∂u_{k−1} (None: a constant α) of flights 1 … K, ``(batch, K)``.
    jitter, scatter
        σ and s per row, ``(batch,)``.

    Returns
    -------
    log_like, t0_mean, t0_sd
        Shape ``(batch,)``; ``log_like`` is −inf where a row is not finite or an onset has
        no variance.
    """
    run = _filter(data, impacts, slopes, jitter, scatter, propagation)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_like = t0_marginal(run.q_rr - run.q_r1**2 / run.q_11, run.log_det, run.q_11,
                               data.n_onsets)
        t0_mean = run.centre + run.q_r1 / run.q_11
        t0_sd = 1.0 / np.sqrt(run.q_11)
    ok = np.isfinite(log_like)
    return (np.where(ok, log_like, -np.inf), np.where(ok, t0_mean, np.nan),
            np.where(ok, t0_sd, np.nan))


def scatter_pointwise(data: OnsetData, impacts: NDArray, slopes: NDArray, jitter: NDArray,
                      scatter: NDArray, propagation: NDArray | None = None) -> NDArray:
    """log p(t_i | t_{−i}, θ) per row and onset, shape ``(batch, n_onsets)``: the terms
    PSIS-LOO needs for a non-factorised Gaussian (Bürkner, Gabry & Vehtari 2021).

    With T0 flat and integrated out, the residuals r have the (improper) precision
    P = Σ⁻¹ − Σ⁻¹11ᵀΣ⁻¹ / (1ᵀΣ⁻¹1), and the conditional of r_i given the others is
    N(r_i − (P r)_i / P_ii, 1 / P_ii); with Σ diagonal this is
    :func:`~drumroll.inference.loo.conditional_pointwise`. Σ⁻¹r, Σ⁻¹1 and the diagonal of
    Σ⁻¹ come from the filter of :func:`scatter_marginal` and one pass back along the roll,
    O(K) per row. The filter maps the onsets y to its innovations ν = L⁻¹y through the
    predicted state â_{i+1} = A_i â_i + B_i y_i, ν_i = y_i − Z â_i (A_i = Φ_i (I − M_i Z),
    B_i = Φ_i M_i, Z = (0, 1): the state's d); so Σ⁻¹y = L⁻ᵀ F⁻¹ ν is that map's adjoint
    applied to g = F⁻¹ν,

        u_i = g_i + B_iᵀ λ_{i+1},    λ_i = A_iᵀ λ_{i+1} − Zᵀ g_i    (λ_{n+1} = 0),

    and (Σ⁻¹)_ii = Σ_j (∂ν_j/∂y_i)² / F_j = 1/F_i + B_iᵀ N_{i+1} B_i with
    N_i = ZᵀZ / F_i + A_iᵀ N_{i+1} A_i (N_{n+1} = 0).
    """
    run = _filter(data, impacts, slopes, jitter, scatter, propagation, keep=True)
    batch, n = impacts.shape[0], data.n_onsets
    solved = np.empty((2, batch, n))  # Σ⁻¹r, Σ⁻¹1
    diagonal = np.empty((batch, n))
    lam_w, lam_d = np.zeros((2, batch)), np.zeros((2, batch))
    n_ww, n_wd, n_dd = np.zeros(batch), np.zeros(batch), np.zeros(batch)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for i in range(n - 1, -1, -1):
            f = run.variance[i]
            g = run.innovation[i] / f
            m_w, m_d = run.gain[i]
            phi_ww, phi_dw = run.transition[i]
            b_w, b_d = phi_ww * m_w, phi_dw * m_w + m_d  # B_i = Φ_i M_i
            solved[:, :, i] = g + b_w * lam_w + b_d * lam_d
            diagonal[:, i] = 1.0 / f + b_w * (b_w * n_ww + 2.0 * b_d * n_wd) + b_d * b_d * n_dd
            # A_i = [[Φww, −Φww m_w], [Φdw, 1 − m_d − Φdw m_w]]
            a_ww, a_wd = phi_ww, -phi_ww * m_w
            a_dw, a_dd = phi_dw, 1.0 - m_d - phi_dw * m_w
            lam_w, lam_d = a_ww * lam_w + a_dw * lam_d, a_wd * lam_w + a_dd * lam_d - g
            # N_i = ZᵀZ / F_i + A_iᵀ N_{i+1} A_i
            t_ww = n_ww * a_ww + n_wd * a_dw  # (N A) columns
            t_dw = n_wd * a_ww + n_dd * a_dw
            t_wd = n_ww * a_wd + n_wd * a_dd
            t_dd = n_wd * a_wd + n_dd * a_dd
            n_ww, n_wd, n_dd = (a_ww * t_ww + a_dw * t_dw, a_ww * t_wd + a_dw * t_dd,
                                a_wd * t_wd + a_dd * t_dd + 1.0 / f)
        solved_r, solved_1 = solved
        total = solved_1.sum(axis=1)  # 1ᵀΣ⁻¹1
        p_r = solved_r - solved_1 * (solved_r.sum(axis=1) / total)[:, None]
        p_ii = diagonal - solved_1**2 / total[:, None]
        return 0.5 * (np.log(p_ii) - _LOG_2PI) - 0.5 * p_r**2 / p_ii


def scatter_noise(data: OnsetData, slopes: NDArray, jitter: NDArray, scatter: NDArray,
                  propagation: NDArray | None, rng: np.random.Generator) -> NDArray:
    """One draw of the onsets' noise per row, N(0, Σ), shape ``(batch, n_onsets)``: the
    restitution's ε_k drawn bounce by bounce and carried through the walk of
    :func:`scatter_marginal` (w by its recursion, d by the flights' slopes), plus the
    independent timing noise: O(K) per row, and Σ's own distribution exactly."""
    batch = slopes.shape[0]
    eps = np.asarray(scatter, float)[:, None] * rng.standard_normal(slopes.shape)
    if propagation is None:
        walk = np.cumsum(eps, axis=1)
    else:  # w_k = P_k Σ_{j≤k} ε_j / P_j, P_k = Π_{i≤k} p_i
        carried = np.cumprod(propagation, axis=1)
        walk = carried * np.cumsum(eps / carried, axis=1)
    moved = np.zeros((batch, slopes.shape[1] + 1))
    np.cumsum(slopes * walk, axis=1, out=moved[:, 1:])  # d_0 … d_K
    scale = np.sqrt(np.asarray(jitter, float)[:, None] ** 2 + data.sigmas**2)
    return data.at_onsets(moved) + scale * rng.standard_normal(scale.shape)


def _by_rows(solve: Callable[[NDArray], Any], good: NDArray) -> list[tuple[NDArray, Any]]:
    """``solve`` of the rows ``good`` (an index array) at once, as ``[(good, result)]``; where
    a row's system is singular (:class:`numpy.linalg.LinAlgError`, rare), one row at a time,
    the failing rows left out."""
    if not good.size:
        return []
    try:
        return [(good, solve(good))]
    except np.linalg.LinAlgError:
        parts = []
        for row in good:
            rows = np.array([row])  # an index array: a length-1 result stays an array
            try:
                parts.append((rows, solve(rows)))
            except np.linalg.LinAlgError:
                continue
        return parts


#: Most Newton steps of :func:`student_t_laplace`, and the change of every residual (in units
#: of its scale), or the fall of −ln of the integrand (nats), under which the mode has been
#: found.
LAPLACE_ITERATIONS, LAPLACE_TOLERANCE = 10, 1e-7

#: Floors, as shares of the t's reweighting weight (ν + 1) / (ν σ² + u²), of the curvature
#: in a Newton step of :func:`student_t_laplace` and in its determinant (comments there).
STEP_FLOOR, CURVATURE_FLOOR = 0.05, 0.02


def scatter_spread(covariance: NDArray, scale2: NDArray) -> NDArray:
    """S = s² G Gᵀ, the scatter's part of ``covariance`` (:func:`onset_covariance`), whose
    diagonal noise is ``scale2`` = σ² + s_i² ``(batch, n)``."""
    spread = covariance.copy()
    i = np.arange(spread.shape[1])
    spread[:, i, i] -= scale2
    return spread


def student_t_laplace(residual: NDArray, spread: NDArray, scale2: NDArray,
                      nu: NDArray | float) -> tuple[NDArray, NDArray, NDArray]:
    """ln ∫∫ Π_i t_ν(r_i − T0 − (A z)_i; σ_i) N(z; 0, I) dz dT0 / W by Laplace's method, and
    T0's mode and sd (module docstring).

    Parameters
    ----------
    residual
        r: the onsets less the noise-free impacts (T0 not taken off), ``(batch, n)``.
    spread
        S = A Aᵀ = s² G Gᵀ, ``(batch, n, n)`` (:func:`scatter_spread`).
    scale2
        The t's squared scale per onset, σ² + s_i², ``(batch, n)``.
    nu
        Degrees of freedom, ``(batch,)`` or a number.

    Returns
    -------
    log_like, t0_mode, t0_sd
        ``(batch,)`` each; ``log_like`` is −inf (and T0 NaN) where a row is not finite or its
        system is singular.
    """
    return _student_t_mode(residual, spread, scale2, nu)[:3]


def _student_t_mode(residual: NDArray, spread: NDArray, scale2: NDArray, nu: NDArray | float,
                    start: NDArray | None = None
                    ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """:func:`student_t_laplace`, and the residuals u left at the mode ``(batch, n)`` (NaN
    where a row has no estimate). ``start``: each onset's u² ``(batch, n)`` to weigh the
    first step's least squares by (iteratively reweighted least squares' weights
    (ν + 1) / (ν σ² + u²)), e.g. those of a nearby problem's mode; by default u = 0, the
    Gaussian of the t's curvature at its centre."""
    nu = np.asarray(nu, float)
    nu = np.broadcast_to(nu[:, None] if nu.ndim else nu, residual.shape)
    batch = residual.shape[0]
    out = np.full((3, batch), np.nan)
    out[0] = -np.inf
    mode = np.full(residual.shape, np.nan)
    good = np.flatnonzero(np.isfinite(residual).all(axis=1)
                          & np.isfinite(spread).all(axis=(1, 2))
                          & np.isfinite(scale2).all(axis=1) & (scale2 > 0).all(axis=1)
                          & np.isfinite(nu).all(axis=1))
    if start is not None:
        good = good[np.isfinite(start[good]).all(axis=1)]
    # T0 is flat: centring the residuals changes nothing but the round-off.
    centre = np.zeros(batch)
    if good.size:
        centre[good] = residual[good].mean(axis=1)
    centred = residual - centre[:, None]

    def solve(rows: NDArray) -> tuple[NDArray, ...]:
        return _laplace(centred[rows], spread[rows], scale2[rows], nu[rows],
                        None if start is None else start[rows])

    for rows, (log_like, t0, t0_sd, u) in _by_rows(solve, good):
        ok = np.isfinite(log_like)
        out[0, rows] = np.where(ok, log_like, -np.inf)
        out[1, rows] = np.where(ok, t0 + centre[rows], np.nan)
        out[2, rows] = np.where(ok, t0_sd, np.nan)
        mode[rows] = np.where(ok[:, None], u, np.nan)
    return out[0], out[1], out[2], mode


def _bordered_solve(spread: NDArray, inverse_weight: NDArray, top: NDArray, bottom: NDArray
                    ) -> tuple[NDArray, NDArray]:
    """Solve [[S + diag(inverse_weight), 1], [1ᵀ, 0]] [y; T0] = [top; bottom] per row."""
    batch, n = top.shape
    system = np.zeros((batch, n + 1, n + 1))
    system[:, :n, :n] = spread
    i = np.arange(n)
    system[:, i, i] += inverse_weight
    system[:, :n, n] = 1.0
    system[:, n, :n] = 1.0
    right = np.concatenate([top, bottom[:, None]], axis=1)
    solution = np.linalg.solve(system, right[..., None])[..., 0]
    return solution[:, :n], solution[:, n]


def _laplace(r: NDArray, spread: NDArray, c2: NDArray, nu: NDArray,
             start: NDArray | None = None) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """:func:`_student_t_mode` of finite rows, ``r`` centred; ``nu`` ``(batch, n)``. Raises
    :class:`numpy.linalg.LinAlgError` when a row's system is singular."""
    n = r.shape[1]
    nu_c2 = nu * c2
    # Start from the Gaussian of the t's curvature at its centre, ν σ² / (ν + 1): the mode
    # where every onset lies in the t's core (generalised least squares for T0 and the walk);
    # or, given each onset's u² at a nearby mode, from least squares reweighted by them.
    y, t0 = _bordered_solve(spread, (nu_c2 if start is None else nu_c2 + start) / (nu + 1.0),
                            r, np.zeros(r.shape[0]))
    sy = (spread @ y[..., None])[..., 0]
    u = r - t0[:, None] - sy
    objective = _objective(u, y, sy, nu, nu_c2)
    active = np.arange(r.shape[0])  # rows not yet settled: each stops on its own
    for _ in range(LAPLACE_ITERATIONS):
        if not active.size:
            break
        a_u, a_y, a_t0 = u[active], y[active], t0[active]
        a_nu, a_nu_c2, a_spread = nu[active], nu_c2[active], spread[active]
        q = a_nu_c2 + a_u * a_u
        # The t's curvature (Newton's step) where it is at least STEP_FLOOR (a twentieth)
        # of the reweighting weight (ν + 1) / (ν σ² + u²), that much beyond, about and past
        # the inflection point (a damped reweighting step, which keeps the system definite
        # and the step short where an onset lies in the t's tail; a larger floor converges
        # linearly for onsets a few σ out, as a roll's last onsets often are). The step
        # solves (I + D S) Δy + D 1 ΔT0 = ψ − y and 1ᵀ Δy = −1ᵀ y, divided through by D to be
        # symmetric.
        weight = np.maximum((a_nu + 1.0) * (a_nu_c2 - a_u * a_u) / (q * q),
                            STEP_FLOOR * (a_nu + 1.0) / q)
        step_y, step_t0 = _bordered_solve(a_spread, 1.0 / weight,
                                          ((a_nu + 1.0) * a_u / q - a_y) / weight,
                                          -a_y.sum(axis=1))
        for _ in range(20):
            moved, moved_t0 = a_y + step_y, a_t0 + step_t0
            moved_sy = (a_spread @ moved[..., None])[..., 0]
            moved_u = r[active] - moved_t0[:, None] - moved_sy
            moved_objective = _objective(moved_u, moved, moved_sy, a_nu, a_nu_c2)
            # A rise within the tolerance is no rise: at the mode a full step moves F by
            # rounding alone, either way, and halving it twenty times would find no fall.
            rising = moved_objective > objective[active] + LAPLACE_TOLERANCE
            if not rising.any():
                break
            step_y[rising] *= 0.5
            step_t0[rising] *= 0.5
        # A step that would raise F after all its halvings is not taken: the row has settled
        # as far as rounding lets it.
        taken = ~rising
        # Settled too when F no longer falls by more than LAPLACE_TOLERANCE: where an onset
        # lies in a tail the damped step converges only linearly, and the estimate's error
        # at such a point is of the order of what F has left to fall.
        settled = rising | (objective[active] - moved_objective < LAPLACE_TOLERANCE) | (
            np.max(np.abs(moved_u - a_u) / np.sqrt(c2[active]), axis=1) < LAPLACE_TOLERANCE)
        rows = active[taken]
        y[rows], t0[rows], u[rows] = moved[taken], moved_t0[taken], moved_u[taken]
        sy[rows] = moved_sy[taken]
        objective[rows] = moved_objective[taken]
        active = active[~settled]
    # Curvature of −ln t at the mode, at least CURVATURE_FLOOR (a fiftieth) of the t's
    # reweighting weight (a floor that binds only about and past the inflection point,
    # |u| = √ν σ, where the curvature falls to 0 and below): with none, a point whose onsets
    # all lie in the tails would leave T0 no curvature at all, and its Laplace estimate
    # unbounded.
    q = nu_c2 + u * u
    curvature = np.maximum((nu + 1.0) * (nu_c2 - u * u) / (q * q),
                           CURVATURE_FLOOR * (nu + 1.0) / q)
    root = np.sqrt(curvature)
    hessian = root[:, :, None] * spread * root[:, None, :]
    i = np.arange(n)
    hessian[:, i, i] += 1.0
    factor = np.linalg.cholesky(hessian)  # M = I + D^½ S D^½
    log_t = student_t_logpdf(u * u / c2, nu, 0.5 * np.log(c2)).sum(axis=1)
    z2 = np.sum(y * sy, axis=1)  # |z*|² = yᵀ S y
    log_det = 2.0 * np.log(np.diagonal(factor, axis1=1, axis2=2)).sum(axis=1)
    # T0's precision under the Laplace Gaussian: 1ᵀ D^½ M⁻¹ D^½ 1 = |w|², w = L⁻¹ D^½ 1.
    both = np.linalg.solve(factor, np.concatenate([root[:, :, None],
                                                   root[:, :, None] * spread], axis=2))
    w, x = both[:, :, 0], both[:, :, 1:]
    precision = np.einsum("bi,bi->b", w, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        # The covariance of the residuals' displacements under the Laplace Gaussian: the
        # walk's given T0, m0 = A (I + Aᵀ D A)⁻¹ Aᵀ = S − Xᵀ X (X = L⁻¹ D^½ S, Woodbury),
        # and T0's, which carries the walk with it by −m0 D 1 per unit (c = 1 − m0 D 1).
        m0 = spread - np.swapaxes(x, 1, 2) @ x
        carried = 1.0 - (m0 @ curvature[..., None])[..., 0]
        m = m0 + carried[:, :, None] * carried[:, None, :] / precision[:, None, None]
        # The next order of Laplace's expansion (the t's third and fourth derivatives, each
        # onset a factor of its own):
        #   δ = −⅛ Σ_i ρ⁗_i m_ii² + ⅛ Σ_ij ρ‴_i ρ‴_j m_ii m_ij m_jj + (1/12) Σ_ij ρ‴_i ρ‴_j m_ij³.
        # A t's core is flatter than a Gaussian's, so Laplace alone falls short by up to
        # 0.17 nat (ν = 4) for every direction that one onset pins; this recovers most of it.
        # Powers as products: numpy's ** for an exponent other than 2 calls pow() per
        # element, a hundred times slower (m**3 alone was a fifth of LOO's terms).
        u2, q2 = u * u, q * q
        third = 2.0 * (nu + 1.0) * u * (u2 - 3.0 * nu_c2) / (q2 * q)
        fourth = -6.0 * (nu + 1.0) * (u2 * u2 - 6.0 * nu_c2 * u2 + nu_c2 * nu_c2) / (q2 * q2)
        m_ii = np.diagonal(m, axis1=1, axis2=2)
        a = third * m_ii
        correction = (-0.125 * np.sum(fourth * m_ii**2, axis=1)
                      + 0.125 * np.sum(a * (m @ a[..., None])[..., 0], axis=1)
                      + np.sum(third * ((m * m * m) @ third[..., None])[..., 0], axis=1) / 12.0)
        # The term is a series in how far the t's are from Gaussian over the posterior's
        # width; far from the data (an onset's t curving on a scale much finer than T0's
        # spread) it is not small and means nothing. What it corrects is bounded: each onset's
        # t factor, integrated over a direction it pins alone, exceeds its Laplace estimate by
        # c_ν = −ln(t_ν(0) √(2π ν / (ν + 1))) (0.17 nat at ν = 4, 0.57 at ν = 1, 0 as ν → ∞),
        # and a direction it does not pin gains less; so the correction is held within n c_ν.
        row_nu = nu[:, 0]  # one ν per row
        bound = -n * (student_t_logpdf(0.0, row_nu)
                      + 0.5 * np.log(2.0 * math.pi * row_nu / (row_nu + 1.0)))
        correction = np.clip(correction, -bound, bound)
        log_like = (log_t - 0.5 * z2 - 0.5 * log_det - 0.5 * np.log(precision)
                    + 0.5 * _LOG_2PI - math.log(T0_WINDOW_S) + correction)
        t0_sd = 1.0 / np.sqrt(precision)
    return np.where(precision > 0, log_like, -np.inf), t0, t0_sd, u


def _objective(u: NDArray, y: NDArray, sy: NDArray, nu: NDArray, nu_c2: NDArray
               ) -> NDArray:
    """−ln of Laplace's integrand up to a constant: Σ ρ(u_i) + ½ |z|², |z|² = yᵀ S y (``sy``
    is S y)."""
    return (0.5 * np.sum((nu + 1.0) * np.log1p(u * u / nu_c2), axis=1)
            + 0.5 * np.sum(y * sy, axis=1))


def student_t_scatter_noise(spread: NDArray, scale2: NDArray, nu: NDArray | float,
                            rng: np.random.Generator) -> NDArray:
    """One draw of the onsets' noise per row under Student-t noise: the scatter's walk
    N(0, S) (S may be singular: the first impact moves with no ε) plus independent t_ν noise
    of scale √``scale2``, shape ``(batch, n)``."""
    values, vectors = np.linalg.eigh(spread)
    walk = np.einsum("bij,bj->bi", vectors,
                     np.sqrt(np.maximum(values, 0.0)) * rng.standard_normal(scale2.shape))
    nu = np.asarray(nu, float)
    nu = np.broadcast_to(nu[:, None] if nu.ndim else nu, scale2.shape)
    return walk + np.sqrt(scale2) * rng.standard_t(nu)


def student_t_laplace_pointwise(residual: NDArray, spread: NDArray, scale2: NDArray,
                                nu: NDArray | float) -> NDArray:
    """LOO's terms ln p(t_i | t_{−i}, θ) = ln p(t) − ln p(t_{−i}) under Student-t noise, each
    by :func:`student_t_laplace` (T0 integrated out in both), shape ``(batch, n)``.

    Each ln p(t_{−i}) starts from least squares weighed as the mode of ln p(t) weighs the
    other onsets: leaving one onset out moves the mode a little, and iteratively reweighted
    least squares from the weights it settled on starts next to it."""
    batch, n = residual.shape
    full, _, _, u = _student_t_mode(residual, spread, scale2, nu)
    out = np.empty((batch, n))
    for i in range(n):
        keep = np.delete(np.arange(n), i)
        out[:, i] = full - _student_t_mode(residual[:, keep], spread[:, keep][:, :, keep],
                                           scale2[:, keep], nu, start=u[:, keep] ** 2)[0]
    return out
