"""Bayesian evidence by nested sampling (dynesty), for log Bayes factors between models.

The likelihood and priors are exactly those emcee samples (:class:`LogPosterior`); with
Gaussian noise T0 is marginalised over the same flat window in every model, so that constant
cancels in a Bayes factor.
"""

from __future__ import annotations

from dataclasses import dataclass

import dynesty
import numpy as np
from numpy.typing import NDArray

from drumroll.inference.posterior import LogPosterior


@dataclass(frozen=True)
class Evidence:
    """ln Z of one model and its numerical uncertainty.

    Attributes
    ----------
    log_z, log_z_err
        ln Z and dynesty's estimate of its error.
    n_calls
        Likelihood evaluations used.
    """

    log_z: float
    log_z_err: float
    n_calls: int


def compute_evidence(log_posterior: LogPosterior, seed: int = 0, n_live: int = 200,
                     dlogz: float = 0.1) -> Evidence:
    """ln Z = ln ∫ L(θ) π(θ) dθ by static nested sampling.

    Parameters
    ----------
    log_posterior
        Supplies the likelihood, the prior transform and the dimension.
    seed
        Seed of dynesty's generator.
    n_live
        Live points; the error of ln Z falls as 1/sqrt(n_live).
    dlogz
        Stop when the remaining evidence is below this (in ln Z).
    """
    space = log_posterior.space

    def log_likelihood(x: NDArray) -> float:
        value = float(log_posterior.log_likelihood(x[None, :])[0])
        # dynesty needs a finite floor for points the physics forbids.
        return value if np.isfinite(value) else -1e300

    def prior_transform(u: NDArray) -> NDArray:
        return space.prior_transform(u)

    sampler = dynesty.NestedSampler(log_likelihood, prior_transform, space.ndim,
                                    nlive=n_live, bound="multi", sample="rwalk",
                                    rstate=np.random.default_rng(seed))
    sampler.run_nested(dlogz=dlogz, print_progress=False)
    results = sampler.results
    return Evidence(log_z=float(results.logz[-1]), log_z_err=float(results.logzerr[-1]),
                    n_calls=int(np.sum(results.ncall)))
