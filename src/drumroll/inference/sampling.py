"""emcee sampling until the autocorrelation time can be trusted."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import arviz as az
import emcee
import numpy as np
from numpy.typing import NDArray

from drumroll.inference.mode import find_mode
from drumroll.inference.posterior import LogPosterior


@dataclass(frozen=True)
class SamplerSettings:
    """The ``[sampler]`` section.

    Attributes
    ----------
    walkers
        Number of emcee walkers (at least 2 × ndim + 2; raised when smaller).
    max_steps
        Stop here even if the chain is not yet 50 τ long (a diagnostic then says so).
    tau_multiple
        Chain length, in autocorrelation times, that makes τ trusted (emcee's advice: 50).
    max_r_hat, min_ess
        The run also goes on until every parameter's rank-normalised split R-hat (walkers as
        chains) is below ``max_r_hat`` and its bulk and tail ESS reach ``min_ess``.
    seed
        Seed of everything random in the run.
    check_every
        Steps between autocorrelation checks.
    """

    walkers: int = 32
    max_steps: int = 20_000
    tau_multiple: float = 50.0
    max_r_hat: float = 1.01
    min_ess: float = 400.0
    seed: int = 0
    check_every: int = 500


@dataclass(frozen=True)
class Chain:
    """A finished emcee run, burn-in discarded and thinned.

    Attributes
    ----------
    samples
        Shape ``(walkers, draws, ndim)``: walkers are ArviZ's chains.
    log_prob
        Shape ``(walkers, draws)``.
    tau
        Integrated autocorrelation time per parameter (steps).
    acceptance
        Mean acceptance fraction over the walkers.
    n_steps, burn, thin
        Steps run, steps discarded, thinning factor.
    converged
        Whether the chain reached ``tau_multiple`` × τ before ``max_steps``.
    mode
        The posterior mode the walkers started from.
    """

    samples: NDArray
    log_prob: NDArray
    tau: NDArray
    acceptance: float
    n_steps: int
    burn: int
    thin: int
    converged: bool
    mode: NDArray


def initial_ball(log_posterior: LogPosterior, centre: NDArray, walkers: int,
                 rng: np.random.Generator) -> NDArray:
    """Walkers in a small ball around ``centre``, each at a finite posterior."""
    prior_spread = np.std(log_posterior.space.sample_prior(rng, 4000), axis=0)
    width = np.where(prior_spread > 0, 1e-4 * prior_spread, 1e-8)
    ball = centre + width * rng.standard_normal((walkers, centre.size))
    for _ in range(100):
        bad = ~np.isfinite(log_posterior(ball))
        if not bad.any():
            return ball
        ball[bad] = centre + 0.5 * (ball[bad] - centre)
    ball[~np.isfinite(log_posterior(ball))] = centre
    return ball


def run_emcee(log_posterior: LogPosterior, settings: SamplerSettings,
              progress: Callable[[int, int], None] | None = None) -> Chain:
    """Sample until the chain is ``tau_multiple`` autocorrelation times long.

    Differential-evolution moves (80 % DE, 20 % DE snooker) are used rather than the stretch
    move: d, h and the release speed lie along a ridge where the stretch move mixes slowly
    (physics.md). The walkers start in a ball around the mode (:func:`find_mode`). After the
    run, ``3 τ_max`` steps are discarded and the chain is thinned by ``τ_min / 2``.

    Parameters
    ----------
    log_posterior
        The vectorised target.
    settings
        Walkers, step limit, seed.
    progress
        Called as ``progress(step, max_steps)`` every ``check_every`` steps.
    """
    rng = np.random.default_rng(settings.seed)
    ndim = log_posterior.space.ndim
    walkers = max(settings.walkers, 2 * ndim + 2)
    mode = find_mode(log_posterior, rng)
    start = initial_ball(log_posterior, mode, walkers, rng)
    sampler = emcee.EnsembleSampler(
        walkers, ndim, log_posterior, vectorize=True,
        moves=[(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)])
    sampler._random.seed(settings.seed)  # emcee's own RandomState: deterministic moves
    state, converged = start, False
    tau = np.full(ndim, np.nan)
    while sampler.iteration < settings.max_steps:
        steps = min(settings.check_every, settings.max_steps - sampler.iteration)
        state = sampler.run_mcmc(state, steps, progress=False)
        if progress is not None:
            progress(sampler.iteration, settings.max_steps)
        tau = sampler.get_autocorr_time(tol=0)
        if not (np.all(np.isfinite(tau))
                and sampler.iteration >= settings.tau_multiple * tau.max()):
            continue
        burn, thin = _burn_and_thin(tau, sampler.iteration)
        if _diagnostics_pass(sampler.get_chain(discard=burn, thin=thin), settings):
            converged = True
            break
    burn, thin = _burn_and_thin(tau, sampler.iteration)
    samples = sampler.get_chain(discard=burn, thin=thin)  # (draws, walkers, ndim)
    log_prob = sampler.get_log_prob(discard=burn, thin=thin)
    return Chain(samples=np.swapaxes(samples, 0, 1), log_prob=log_prob.T, tau=tau,
                 acceptance=float(np.mean(sampler.acceptance_fraction)),
                 n_steps=sampler.iteration, burn=burn, thin=thin, converged=converged,
                 mode=mode)


def _burn_and_thin(tau: NDArray, n_steps: int) -> tuple[int, int]:
    """Discard 3 τ_max (at most half the chain); thin by τ_min / 2."""
    finite = np.isfinite(tau)
    tau_max = float(np.max(tau[finite])) if finite.any() else n_steps / 10
    tau_min = float(np.min(tau[finite])) if finite.any() else 1.0
    return min(math.ceil(3 * tau_max), n_steps // 2), max(1, int(tau_min / 2))


def _diagnostics_pass(chain: NDArray, settings: SamplerSettings) -> bool:
    """R-hat and bulk/tail ESS of every parameter meet the settings (walkers as chains)."""
    walkers_first = np.swapaxes(chain, 0, 1)
    for i in range(walkers_first.shape[-1]):
        draws = walkers_first[..., i]
        if not (az.rhat(draws) < settings.max_r_hat
                and az.ess(draws, method="bulk") >= settings.min_ess
                and az.ess(draws, method="tail") >= settings.min_ess):
            return False
    return True
