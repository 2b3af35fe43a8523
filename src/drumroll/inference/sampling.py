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
from drumroll.inference.space import SamplerCoordinates


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
        Targets of the report: every parameter's rank-normalised split R-hat (walkers as
        chains) below ``max_r_hat``, bulk and tail ESS at least ``min_ess``.
    stop_r_hat
        The run goes on until the sampled parameters' R-hat is below this (and their ESS
        reaches ``min_ess``). It is stricter than ``max_r_hat`` because R-hat is itself a noisy
        estimate and the report also covers derived quantities and T0: stopping right at the
        target would leave reported values straddling it.
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
    stop_r_hat: float = 1.005
    seed: int = 0
    check_every: int = 250


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


class SamplerTarget:
    """The log density emcee samples: the posterior in :class:`SamplerCoordinates` z,
    log p(x(z)) + log |det ∂x/∂z| (a plain, picklable callable)."""

    def __init__(self, log_posterior: LogPosterior, coordinates: SamplerCoordinates) -> None:
        self.log_posterior = log_posterior
        self.coordinates = coordinates

    def __call__(self, z: NDArray) -> NDArray:
        x, log_det = self.coordinates.to_parameters(z)
        out = self.log_posterior(x)
        return np.where(np.isfinite(out), out + log_det, -np.inf)


#: emcee's moves: differential evolution with the optimal scale 2.38 / sqrt(2 ndim) and, one
#: step in ten, γ = 1, which jumps between modes (ter Braak 2006). emcee 3.1.6's
#: DESnookerMove normalises its direction by sqrt(|δ|) instead of |δ| and halves the
#: Jacobian term, so it does not keep the target invariant (on a 6-d Gaussian alone it
#: shrinks the variances by ~30 %; dfm/emcee#531); it is not used.
def default_moves() -> list[tuple[emcee.moves.Move, float]]:
    """A fresh list of the moves :func:`run_emcee` uses."""
    return [(emcee.moves.DEMove(), 0.9), (emcee.moves.DEMove(gamma0=1.0), 0.1)]


def run_emcee(log_posterior: LogPosterior, settings: SamplerSettings,
              progress: Callable[[int, int], None] | None = None) -> Chain:
    """Sample until the chain is ``tau_multiple`` autocorrelation times long and the R-hat and
    ESS criteria of ``settings`` hold.

    The walkers move in :class:`~drumroll.inference.space.SamplerCoordinates` (h through
    q = ω_C/γ, the jitter and t_B through their logarithms), where the pendulum's (d, h) ridge
    is nearly straight: with the differential-evolution moves of :func:`default_moves` the
    autocorrelation time falls from ~90 to ~25 steps. Every diagnostic (τ, R-hat, ESS) and
    every output is computed on the model's own parameters. The walkers start in a ball
    around the mode (:func:`find_mode`). After the run, ``3 τ_max`` steps are discarded and
    the chain is thinned by ``τ_min / 2``.

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
    coordinates = SamplerCoordinates(log_posterior.space)
    mode = find_mode(log_posterior, rng)
    start = coordinates.to_sampler(initial_ball(log_posterior, mode, walkers, rng))
    sampler = emcee.EnsembleSampler(walkers, ndim, SamplerTarget(log_posterior, coordinates),
                                    vectorize=True, moves=default_moves())
    sampler._random.seed(settings.seed)  # emcee's own RandomState: deterministic moves
    state, converged = start, False
    tau = np.full(ndim, np.nan)
    while sampler.iteration < settings.max_steps:
        steps = min(settings.check_every, settings.max_steps - sampler.iteration)
        state = sampler.run_mcmc(state, steps, progress=False)
        if progress is not None:
            progress(sampler.iteration, settings.max_steps)
        chain = _parameters(coordinates, sampler.get_chain())[0]
        tau = emcee.autocorr.integrated_time(chain, tol=0)
        if not (np.all(np.isfinite(tau))
                and sampler.iteration >= settings.tau_multiple * tau.max()):
            continue
        burn, thin = _burn_and_thin(tau, sampler.iteration)
        if _diagnostics_pass(chain[burn::thin], settings):
            converged = True
            break
    burn, thin = _burn_and_thin(tau, sampler.iteration)
    samples, log_det = _parameters(coordinates, sampler.get_chain(discard=burn, thin=thin))
    log_prob = sampler.get_log_prob(discard=burn, thin=thin) - log_det  # back to p(x)
    return Chain(samples=np.swapaxes(samples, 0, 1), log_prob=log_prob.T, tau=tau,
                 acceptance=float(np.mean(sampler.acceptance_fraction)),
                 n_steps=sampler.iteration, burn=burn, thin=thin, converged=converged,
                 mode=mode)


def _parameters(coordinates: SamplerCoordinates, chain: NDArray) -> tuple[NDArray, NDArray]:
    """A chain ``(steps, walkers, ndim)`` of z mapped to the parameters, and log |det|."""
    x, log_det = coordinates.to_parameters(chain.reshape(-1, chain.shape[-1]))
    return x.reshape(chain.shape), log_det.reshape(chain.shape[:-1])


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
        if not (az.rhat(draws) < settings.stop_r_hat
                and az.ess(draws, method="bulk") >= settings.min_ess
                and az.ess(draws, method="tail") >= settings.min_ess):
            return False
    return True
