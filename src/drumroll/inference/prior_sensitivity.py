"""How much a Bayes factor owes to the widths of the priors the two models do not share.

The evidence of a model falls as the prior of a parameter the data pin down widens (the Occam
factor): a flat t_B prior twice as wide costs the power law ln 2, and the comparison with a
pendulum, which has no t_B, moves by as much although the data are the same. Widening or
narrowing a prior by a factor f changes the evidence by

    Z_f / Z = E_posterior[ p_f(θ) / p(θ) ]

(importance reweighting of the draws already made: no new sampling), so the Bayes factor of
two models moves by the difference of their shifts over the parameters each has and the other
has not. A Bayes factor that moves by more than :data:`PRIOR_DOMINATED_NATS` when those priors
are half or twice as wide (:data:`WIDTHS`) is "prior-dominated": it says more about the
priors than about the data, and the verdict does not rest on it.

Importance reweighting fails in one case that matters here: a normal prior made wider over a
parameter the data say little about (a stick's lengths, the pivot along the (d, h) ridge).
There p_f / p = exp(3 z² / 8) / 2 in the prior's z, unbounded, and over a posterior that
follows the prior its tail is Pareto with k = 3/4 (k = 3 v / 4 for a posterior variance v
prior variances): past the 1/2 at which the weights' variance is infinite and the 0.7 past
which PSIS calls an estimate unreliable (Vehtari et al. 2024). The mean of such weights is
low and scatters: for table2_h110's four geometry priors doubled (true shift −0.90 nat under
a Gaussian likelihood), 1000 draws gave −1.01 in the median and past −1 nat (the flag's line)
one time in two; 64,000 draws, one in 25. So the parameters whose prior is Gaussian in some
coordinate (normal in x, log-normal in ln x) are not reweighted: their likelihood, taken as
Gaussian with the precision and the information vector that the posterior's mean and
covariance imply in the prior's standard coordinates, is integrated against the narrowed or
widened prior in closed form (:func:`gaussian_log_evidence_shift`), which is exact when the
posterior in them is Gaussian and never needs a weight. The other families (flat ranges: a
weight of 0 or 1/f; half-normal scales, whose posterior is seldom Gaussian) are reweighted,
and the two parts are added (the posterior taken as independent between them).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping

import numpy as np

from drumroll.distributions import Distribution, LogNormal, Normal
from drumroll.quantities import BY_NAME

#: Width factors of the check: the priors of the non-shared parameters half and twice as wide.
WIDTHS = (0.5, 2.0)
#: A Bayes factor that moves by more than this (nats) under :data:`WIDTHS` is prior-dominated.
PRIOR_DOMINATED_NATS = 1.0


def log_evidence_shift(posterior, priors: Mapping[str, Distribution], names: Collection[str],
                       factor: float) -> float | None:
    """ln Z_f − ln Z when the priors of ``names`` are ``factor`` times as wide: in closed form
    for the normal and log-normal priors (:func:`gaussian_log_evidence_shift`, their
    truncation's mass included), by reweighting the draws for the rest and for those where
    the draws' covariance is singular (module docstring).

    Parameters
    ----------
    posterior
        The model's posterior draws: ArviZ's ``posterior`` group (user units, summary keys).
    priors
        The model's priors by internal name (SI).
    names
        The parameters whose priors change (internal names).
    factor
        Width factor (:meth:`~drumroll.distributions.Distribution.widened`).

    Returns
    -------
    float or None
        None when a prior has no width to scale, or no draw lies inside a narrowed prior.
    """
    if not names:
        return 0.0
    gaussian = sorted(name for name in names if isinstance(priors[name], (Normal, LogNormal)))
    shift = 0.0
    if gaussian:
        y = np.stack([_standard(priors[name], _draws(posterior, name)) for name in gaussian],
                     axis=-1)
        closed = gaussian_log_evidence_shift(y, factor)
        if closed is None:  # no covariance to take a likelihood from: reweight them too
            gaussian = []
        else:
            shift = closed + sum(priors[name].log_mass - priors[name].widened(factor).log_mass
                                 for name in gaussian)
    reweighted = [name for name in names if name not in gaussian]
    if not reweighted:
        return float(shift)
    log_ratio = 0.0
    for name in reweighted:
        wide = priors[name].widened(factor)
        if wide is None:
            return None
        x = _draws(posterior, name)
        log_ratio = log_ratio + wide.logpdf(x) - priors[name].logpdf(x)
    top = np.max(log_ratio)
    if not np.isfinite(top):
        return None
    return float(shift + top + math.log(np.mean(np.exp(log_ratio - top))))


def gaussian_log_evidence_shift(y: np.ndarray, factor: float) -> float | None:
    """ln Z_f − ln Z for a standard normal prior on ``y`` made ``factor`` times as wide, the
    likelihood Gaussian in ``y``, from the posterior's draws ``y`` ``(n, k)``.

    With the posterior's mean m and covariance C, the likelihood's precision is
    Λ = C⁻¹ − I (its eigenvalues λ clipped at 0: a direction the data do not inform) and its
    information vector b = C⁻¹ m. Along each eigenvector, ∫ exp(−λ (y − a)² / 2) N(y; 0, f²)
    dy ∝ (1 + λ f²)^(−1/2) exp(−λ a² / (2 (1 + λ f²))) with λ a = b, so that

        ln Z_f − ln Z = Σ −½ ln((1 + λ f²) / (1 + λ)) + ½ b² (f² − 1) / ((1 + λ f²)(1 + λ)),

    which tends to −ln f where the data pin the direction down (λ → ∞) and to 0 where they
    say nothing (λ = 0, b = 0), with no division by λ. None when the draws' covariance is
    singular (fewer draws than columns, or a column that does not vary).
    """
    y = np.asarray(y, float).reshape(-1, np.shape(y)[-1])
    if y.shape[0] <= y.shape[1] or not np.all(np.isfinite(y)):
        return None
    mean = y.mean(axis=0)
    covariance = np.atleast_2d(np.cov(y, rowvar=False))
    try:
        np.linalg.cholesky(covariance)
    except np.linalg.LinAlgError:
        return None
    precision = np.linalg.inv(covariance)
    lam, vectors = np.linalg.eigh(precision - np.eye(mean.size))
    lam = np.clip(lam, 0.0, None)
    b = vectors.T @ (precision @ mean)
    f2 = factor * factor
    return float(np.sum(-0.5 * np.log((1.0 + lam * f2) / (1.0 + lam))
                        + 0.5 * b * b * (f2 - 1.0) / ((1.0 + lam * f2) * (1.0 + lam))))


def _draws(posterior, name: str) -> np.ndarray:
    """The posterior draws of the parameter ``name`` in SI, flat."""
    quantity = BY_NAME[name]
    return quantity.to_si * np.asarray(posterior[quantity.key].values, float).ravel()


def _standard(prior: Normal | LogNormal, x: np.ndarray) -> np.ndarray:
    """``x`` in the standard coordinate of its Gaussian prior: (x − μ) / σ, in ln x for a
    log-normal."""
    return ((np.log(x) if isinstance(prior, LogNormal) else x) - prior.mu) / prior.sigma


def bayes_factor_shifts(main_posterior, main_priors: Mapping[str, Distribution],
                        other_posterior, other_priors: Mapping[str, Distribution]
                        ) -> tuple[tuple[float, float], float] | None:
    """How ln B (main − other) moves when the priors of the parameters only one of the two
    models samples are half or twice as wide (:data:`WIDTHS`).

    Returns
    -------
    (half, double), largest
        The shifts with both models' non-shared priors scaled together, and the largest
        |shift| of any scaling, together or one model's at a time (the two models' Occam
        factors can cancel when scaled together, and a user changes one prior at a time);
        None when a shift cannot be computed.
    """
    main_only = _sampled(main_priors) - _sampled(other_priors)
    other_only = _sampled(other_priors) - _sampled(main_priors)
    together, largest = [], 0.0
    for factor in WIDTHS:
        main = log_evidence_shift(main_posterior, main_priors, main_only, factor)
        other = log_evidence_shift(other_posterior, other_priors, other_only, factor)
        if main is None or other is None:
            return None
        together.append(main - other)
        largest = max(largest, abs(main - other), abs(main), abs(other))
    return (together[0], together[1]), largest


def _sampled(priors: Mapping[str, Distribution]) -> set[str]:
    """The sampled parameters of a model with a registered quantity (its physics and noise;
    T0 and ν of the Student-t noise are shared by construction)."""
    return {name for name, prior in priors.items()
            if not prior.is_fixed and name in BY_NAME and BY_NAME[name].kind != "nuisance"}
