"""Pareto smoothed importance sampling: the k̂ of importance weights (how heavy their right
tail is) and the smoothed weights PSIS-LOO uses.

Vehtari, Simpson, Gelman, Yao & Gabry (2024), "Pareto smoothed importance sampling", JMLR 25:
fit a generalised Pareto distribution to the largest M = min(S/5, 3√S) of S weights (less the
(M+1)-th largest); its shape k̂ says how many finite moments the weights have (1/k̂). Above 0.7
(their threshold for S ≥ 2,200) an importance-sampling estimate and its error cannot be trusted
at any practical S. The fit is Zhang & Stephens (2009)'s empirical-Bayes estimate with the
weakly informative prior on k of Vehtari et al., exactly as ArviZ's ``psislw`` computes it
(tests compare the two); written here so that neither a sampler's worker process (for one
number) nor the estimate (for PSIS-LOO, :func:`drumroll.inference.comparison.loo`) imports
ArviZ.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

#: Zhang & Stephens' prior on b (scaled by the first quartile) and Vehtari et al.'s on k.
_PRIOR_B = 3.0
_PRIOR_K = 10.0


def tail_length(n_weights: int) -> int:
    """M = ⌈min(S/5, 3√S)⌉, the number of largest weights the tail fit uses."""
    return math.ceil(min(n_weights / 5.0, 3.0 * math.sqrt(n_weights)))


def generalised_pareto_shape(exceedances: NDArray) -> float:
    """k̂ of a generalised Pareto fitted to sorted positive ``exceedances`` (Zhang & Stephens
    2009, with Vehtari et al.'s prior pulling k̂ towards 0.5 by 10 pseudo-observations)."""
    return generalised_pareto_fit(exceedances)[0]


def pareto_k(log_weights: NDArray) -> float:
    """k̂ of the right tail of importance weights given by their logarithms (−inf allowed);
    infinite when fewer than 10 are finite or the tail is too short to fit."""
    finite = np.asarray(log_weights, float)
    finite = finite[np.isfinite(finite)]
    if finite.size < 10:
        return math.inf
    finite = np.sort(finite - finite.max())
    m = tail_length(finite.size)
    cutoff = max(finite[-m - 1], math.log(np.finfo(float).tiny))
    tail = finite[finite > cutoff]
    if tail.size <= 4:
        return math.inf
    k = generalised_pareto_shape(np.exp(tail) - math.exp(cutoff))
    return k if math.isfinite(k) else math.inf


def generalised_pareto_fit(exceedances: NDArray) -> tuple[float, float]:
    """k̂ and σ̂ of a generalised Pareto fitted to sorted positive ``exceedances`` (Zhang &
    Stephens 2009's empirical Bayes estimate; k̂ with Vehtari et al.'s prior pulling it
    towards 0.5 by 10 pseudo-observations, σ̂ from the estimate before that, as ArviZ's
    ``_gpdfit``)."""
    x = np.asarray(exceedances, float)
    n = x.size
    grid = 30 + int(math.sqrt(n))
    b = 1.0 - np.sqrt(grid / (np.arange(1, grid + 1) - 0.5))
    b /= _PRIOR_B * x[int(n / 4 + 0.5) - 1]
    b += 1.0 / x[-1]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        k = np.log1p(-b[:, None] * x).mean(axis=1)
        profile = n * (np.log(-(b / k)) - k - 1.0)
        weights = 1.0 / np.exp(profile - profile[:, None]).sum(axis=1)
    keep = weights >= 10 * np.finfo(float).eps
    weights, b = weights[keep], b[keep]
    b_post = float(np.sum(b * weights / weights.sum()))
    k_post = float(np.log1p(-b_post * x).mean())
    return (n * k_post + _PRIOR_K * 0.5) / (n + _PRIOR_K), -k_post / b_post


def _pareto_quantiles(probs: NDArray, k: float, sigma: float) -> NDArray:
    """Quantiles of a generalised Pareto (shape ``k``, scale ``sigma``) at ``probs`` in (0, 1)."""
    if not sigma > 0:
        return np.full_like(probs, np.nan)
    if abs(k) < np.finfo(float).eps:
        return -sigma * np.log1p(-probs)
    # A very heavy tail's top quantiles overflow to inf: harmless, the caller caps them at the
    # largest raw ratio (as ArviZ's psislw does).
    with np.errstate(over="ignore"):
        return sigma * np.expm1(-k * np.log1p(-probs)) / k


def smoothed_log_weights(log_ratios: NDArray, r_eff: float = 1.0) -> tuple[NDArray, float]:
    """Pareto-smoothed importance log weights of one set of draws, normalised, and their k̂
    (PSIS: Vehtari et al. 2024), step for step as ArviZ's ``psislw``: the largest
    ⌈min(S/5, 3√(S/r_eff))⌉ ratios are replaced by the quantiles of a generalised Pareto
    fitted to them and capped at the largest raw ratio; k̂ is infinite (and nothing is
    smoothed) when that tail holds four draws or fewer."""
    x = np.array(log_ratios, float)
    x -= np.max(x)
    n = x.size
    cut = -math.ceil(min(n / 5.0, 3.0 * math.sqrt(n / r_eff))) - 1
    cutoff = max(x[np.argsort(x)[cut]], math.log(np.finfo(float).tiny))
    tail = np.flatnonzero(x > cutoff)
    k = math.inf
    if tail.size > 4:
        order = np.argsort(x[tail])
        k, sigma = generalised_pareto_fit(np.exp(x[tail])[order] - math.exp(cutoff))
        if math.isfinite(k):
            probs = np.arange(0.5, tail.size) / tail.size
            x[tail[order]] = np.log(_pareto_quantiles(probs, k, sigma) + math.exp(cutoff))
            x[x > 0] = 0.0
    top = np.max(x)
    return x - (top + math.log(np.sum(np.exp(x - top)))), k
