"""Bayesian evidence, for log Bayes factors between models: nested sampling (dynesty) and an
independent importance-sampling cross-check from the emcee posterior.

The likelihood and priors are exactly those emcee samples (:class:`LogPosterior`); with
Gaussian noise T0 is marginalised over the same flat window in every model, so that constant
cancels in a Bayes factor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import dynesty
import numpy as np
from numpy.typing import NDArray
from scipy import special

from drumroll.inference.posterior import LogPosterior
from drumroll.inference.priors import LogUniform, Uniform
from drumroll.inference.space import SamplerCoordinates

#: dynesty's floor for points the physics forbids (it needs a finite number).
_FLOOR = -1e300


@dataclass(frozen=True)
class Evidence:
    """ln Z of one model and its numerical uncertainty.

    Attributes
    ----------
    log_z, log_z_err
        ln Z and the estimate of its error (dynesty's, or the importance weights' spread).
    n_calls
        Likelihood evaluations used.
    ess
        Effective sample size of the importance weights (None for nested sampling).
    """

    log_z: float
    log_z_err: float
    n_calls: int
    ess: float | None = None


#: Prior mass left outside the box of an unbounded prior, per tail (ln Z changes by less).
BOX_TAIL = 1e-7


class BoxedProblem:
    """The nested-sampling problem on a box where every prior's unit-cube map is affine.

    Nested sampling only ever needs the product L(θ) π(θ): with any other reference density
    π̃, Z = ∫ L π dθ = ∫ (L π / π̃) π̃ dθ ("posterior repartitioning"). Here π̃ is uniform on a
    box in coordinates y where a uniform prior is uniform (y = x) and a log-uniform prior too
    (y = ln x); a Normal-like prior gets the box [ppf(ε), ppf(1 − ε)] with ε =
    :data:`BOX_TAIL` (all of a bounded support). The unit cube then maps onto y *linearly*,
    instead of through Φ⁻¹: the pendulum's posterior is a needle ~1e-4 of the prior wide
    whose bend under Φ⁻¹ defeated dynesty's random walks (ln Z 1–3 nats low on some seeds
    with 200 live points), while on the box its contours stay nearly ellipsoidal. Only the
    prior mass beyond the box, at most 2ε per parameter, is left out.
    """

    def __init__(self, log_posterior: LogPosterior) -> None:
        space = log_posterior.space
        self.log_posterior = log_posterior
        lower, width = np.empty(space.ndim), np.empty(space.ndim)
        self.log_columns = np.zeros(space.ndim, bool)
        for i, name in enumerate(space.names):
            prior = space.priors[name]
            if type(prior) is Uniform:
                lower[i], upper = prior.support
            elif type(prior) is LogUniform:
                lower[i], upper = (math.log(v) for v in prior.support)
                self.log_columns[i] = True
            else:
                lower[i], upper = float(prior.ppf(BOX_TAIL)), float(prior.ppf(1.0 - BOX_TAIL))
            width[i] = upper - lower[i]
        self.lower, self.width = lower, width
        self.log_volume = float(np.log(width).sum())
        self.any_log = bool(self.log_columns.any())

    def prior_transform(self, u: NDArray) -> NDArray:
        """The unit cube onto the box (y coordinates)."""
        return self.lower + self.width * u

    def parameters(self, y: NDArray) -> NDArray:
        """x from y: exp of the log-uniform columns."""
        if not self.any_log:
            return y
        x = np.array(y, float)
        x[..., self.log_columns] = np.exp(y[..., self.log_columns])
        return x

    def log_likelihood(self, y: NDArray) -> float:
        """ln(L π / π̃) at one y: log posterior + ln |dx/dy| + ln(box volume); finite floor."""
        value = self.log_posterior(self.parameters(y))
        if value == -math.inf:
            return _FLOOR
        if self.any_log:
            value += float(y[self.log_columns].sum())
        return value + self.log_volume


def compute_evidence(log_posterior: LogPosterior, seed: int = 0, n_live: int = 200,
                     dlogz: float = 0.5, sample: str = "rwalk", walks: int | None = None
                     ) -> Evidence:
    """ln Z = ln ∫ L(θ) π(θ) dθ by static nested sampling (dynesty) on :class:`BoxedProblem`.

    Parameters
    ----------
    log_posterior
        Supplies the prior, the likelihood (its one-point path) and the dimension.
    seed
        Seed of dynesty's generator.
    n_live
        Live points; the error of ln Z falls as 1/sqrt(n_live).
    dlogz
        Stop when the evidence still in the live points is below this (ln Z units); dynesty
        then adds the live points' own contribution, so 0.5 changes ln Z by much less than
        its error (and saves ~n_live × ln 5 iterations over 0.1).
    sample, walks
        dynesty's sampling method and random-walk length (dynesty's default 20 + ndim when
        None); multi-ellipsoid bounds.
    """
    problem = BoxedProblem(log_posterior)
    sampler = dynesty.NestedSampler(problem.log_likelihood, problem.prior_transform,
                                    log_posterior.space.ndim, nlive=n_live, bound="multi",
                                    sample=sample, walks=walks,
                                    rstate=np.random.default_rng(seed))
    sampler.run_nested(dlogz=dlogz, print_progress=False)
    results = sampler.results
    return Evidence(log_z=float(results.logz[-1]), log_z_err=float(results.logzerr[-1]),
                    n_calls=int(np.sum(results.ncall)))


def importance_evidence(log_posterior: LogPosterior, posterior_samples: NDArray,
                        rng: np.random.Generator, n: int = 20_000, nu: float = 4.0,
                        inflate: float = 1.2, batch: int = 4096) -> Evidence:
    """ln Z by importance sampling from a Student-t fitted to posterior samples.

    A cross-check of :func:`compute_evidence` that shares nothing with it but the posterior:
    the emcee draws are mapped to :class:`SamplerCoordinates` (where the posterior is nearly
    Gaussian), a multivariate Student-t with ``nu`` degrees of freedom, their mean and
    ``inflate``² times their covariance is fitted (heavier tails than the posterior, so the
    weights have finite variance), and Z = E_q[p(x(z)) |det ∂x/∂z| / q(z)] is averaged over
    ``n`` fresh draws. The error is the weights' standard error, relative to their mean:
    δ ln Z ≈ sd(w) / (mean(w) sqrt(n)); ``ess`` = (Σw)² / Σw² says how well q matches (close
    to ``n`` is good; a few percent of ``n`` means the error itself is unreliable).

    Parameters
    ----------
    log_posterior
        The normalised prior times the likelihood (any callable on ``(batch, ndim)`` works;
        with a ``space`` attribute its sampler coordinates are used).
    posterior_samples
        Draws from the posterior, any shape ending in ndim (e.g. ``Chain.samples``).
    rng
        Source of the proposal draws.
    n
        Number of importance draws.
    nu, inflate
        Tail weight and width of the proposal.
    batch
        Draws per vectorised posterior call.
    """
    samples = np.asarray(posterior_samples, float)
    samples = samples.reshape(-1, samples.shape[-1])
    space = getattr(log_posterior, "space", None)
    coordinates = SamplerCoordinates(space) if space is not None else None
    z = coordinates.to_sampler(samples) if coordinates is not None else samples
    z = z[np.all(np.isfinite(z), axis=1)]
    ndim = z.shape[1]
    mean = z.mean(axis=0)
    cov = np.atleast_2d(np.cov(z, rowvar=False)) * inflate**2
    chol = np.linalg.cholesky(cov)
    log_norm = (special.gammaln(0.5 * (nu + ndim)) - special.gammaln(0.5 * nu)
                - 0.5 * ndim * math.log(nu * math.pi) - np.log(np.diag(chol)).sum())
    log_w = np.empty(n)
    for start in range(0, n, batch):
        m = min(batch, n - start)
        u = rng.standard_normal((m, ndim))
        scale = np.sqrt(nu / rng.chisquare(nu, m))
        draws = mean + scale[:, None] * (u @ chol.T)
        maha = np.einsum("ij,ij->i", u, u) * scale**2
        log_q = log_norm - 0.5 * (nu + ndim) * np.log1p(maha / nu)
        if coordinates is not None:
            x, log_det = coordinates.to_parameters(draws)
        else:
            x, log_det = draws, 0.0
        log_p = np.asarray(log_posterior(x), float) + log_det
        log_w[start:start + m] = np.where(np.isfinite(log_p), log_p - log_q, -np.inf)
    top = np.max(log_w)
    w = np.exp(log_w - top)
    total = w.sum()
    log_z = top + math.log(total / n)
    log_z_err = float(np.std(w) * math.sqrt(n) / total)  # sd(w) / (mean(w) sqrt(n))
    return Evidence(log_z=float(log_z), log_z_err=log_z_err, n_calls=n,
                    ess=float(total**2 / np.sum(w * w)))
