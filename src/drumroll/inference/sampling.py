"""emcee sampling until the autocorrelation time can be trusted."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import arviz as az
import emcee
import numpy as np
from numpy.typing import NDArray

from drumroll.inference.coordinates import SamplerCoordinates
from drumroll.inference.mode import find_mode
from drumroll.inference.posterior import LogPosterior

#: Draws ``(walkers, draws, ndim)`` → every reported quantity, ``(walkers, draws)`` each.
Reported = Callable[[NDArray], dict[str, NDArray]]


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
        The run goes on until every reported quantity (the sampled parameters, and whatever
        ``run_emcee``'s ``reported`` adds: derived quantities, T0) has a rank-normalised split
        R-hat (walkers as chains) below ``max_r_hat`` and bulk and tail ESS of at least
        ``min_ess``. The check is made on exactly the draws that are reported, so the report
        meets these targets whenever the run converged.
    seed
        Seed of everything random in the run.
    check_every
        Fewest steps between convergence checks (they are spaced by a tenth of the chain's
        length once that is more, so their cost stays a small fraction of the run's).
    """

    walkers: int = 32
    max_steps: int = 20_000
    tau_multiple: float = 50.0
    max_r_hat: float = 1.01
    min_ess: float = 400.0
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
        return self.with_parameters(z)[:, 0]

    def with_parameters(self, z: NDArray) -> NDArray:
        """Rows ``[log density, x…, log |det|]``: emcee keeps all but the first column as
        its "blobs", so the chain of parameters needs no second pass through the map."""
        x, log_det, impacts = self.coordinates.to_parameters_and_impacts(z)
        out = self.log_posterior(x) if impacts is None else self.log_posterior(x, impacts)
        density = np.where(np.isfinite(out), out + log_det, -np.inf)
        return np.column_stack([density, x, log_det])


#: emcee's moves: differential evolution with the optimal scale 2.38 / sqrt(2 ndim) and, one
#: step in ten, γ = 1, which jumps between modes (ter Braak 2006). emcee 3.1.6's
#: DESnookerMove normalises its direction by sqrt(|δ|) instead of |δ| and halves the
#: Jacobian term, so it does not keep the target invariant (on a 6-d Gaussian alone it
#: shrinks the variances by ~30 %; dfm/emcee#531); it is not used.
def default_moves() -> list[tuple[emcee.moves.Move, float]]:
    """A fresh list of the moves :func:`run_emcee` uses."""
    return [(emcee.moves.DEMove(), 0.9), (emcee.moves.DEMove(gamma0=1.0), 0.1)]


def run_emcee(log_posterior: LogPosterior, settings: SamplerSettings,
              progress: Callable[[int, int], None] | None = None,
              reported: Reported | None = None) -> Chain:
    """Sample until the chain is ``tau_multiple`` autocorrelation times long and every
    reported quantity meets the R-hat and ESS targets of ``settings``.

    The walkers move in :class:`~drumroll.inference.coordinates.SamplerCoordinates` (h
    through q = ω_C/γ, the jitter and t_B through their logarithms, a sampled T0 through its
    non-centred offset), where the posterior is nearly Gaussian: with the
    differential-evolution moves of :func:`default_moves` the autocorrelation time falls from
    ~90 to ~25–40 steps. Every diagnostic (τ, R-hat, ESS) and every output is computed on the
    model's own parameters. The walkers start in a ball around the mode (:func:`find_mode`).
    After the run, ``3 τ_max`` steps are discarded and the chain is thinned by ``τ_min / 2``.

    Parameters
    ----------
    log_posterior
        The vectorised target.
    settings
        Walkers, step limit, targets, seed.
    progress
        Called as ``progress(step, max_steps)`` at every convergence check.
    reported
        Maps draws ``(walkers, draws, ndim)`` to every quantity that will be reported (name →
        ``(walkers, draws)``); the run stops only when all of them meet the targets. Without
        it, the sampled parameters are checked.
    """
    rng = np.random.default_rng(settings.seed)
    ndim = log_posterior.space.ndim
    walkers = max(settings.walkers, 2 * ndim + 2)
    coordinates = SamplerCoordinates(log_posterior.space, getattr(log_posterior, "data", None))
    mode = find_mode(log_posterior, rng)
    start = coordinates.to_sampler(initial_ball(log_posterior, mode, walkers, rng))
    target = SamplerTarget(log_posterior, coordinates)
    sampler = emcee.EnsembleSampler(walkers, ndim, target.with_parameters, vectorize=True,
                                    moves=default_moves())
    sampler._random.seed(settings.seed)  # emcee's own RandomState: deterministic moves
    state, converged = start, False
    tau = np.full(ndim, np.nan)
    while sampler.iteration < settings.max_steps:
        gap = max(settings.check_every, sampler.iteration // 10)
        steps = min(gap, settings.max_steps - sampler.iteration)
        state = sampler.run_mcmc(state, steps, progress=False)
        if progress is not None:
            progress(sampler.iteration, settings.max_steps)
        chain = sampler.get_blobs()[..., :ndim]
        tau = emcee.autocorr.integrated_time(chain, tol=0)
        if not (np.all(np.isfinite(tau))
                and sampler.iteration >= settings.tau_multiple * tau.max()):
            continue
        burn, thin = _burn_and_thin(tau, sampler.iteration)
        draws = np.swapaxes(sampler.get_blobs(discard=burn, thin=thin)[..., :ndim], 0, 1)
        if _targets_met({str(i): draws[..., i] for i in range(ndim)}, settings) and (
                reported is None or _targets_met(reported(draws), settings)):
            converged = True
            break
    burn, thin = _burn_and_thin(tau, sampler.iteration)
    blobs = sampler.get_blobs(discard=burn, thin=thin)
    log_prob = sampler.get_log_prob(discard=burn, thin=thin) - blobs[..., ndim]  # back to p(x)
    return Chain(samples=np.swapaxes(blobs[..., :ndim], 0, 1), log_prob=log_prob.T, tau=tau,
                 acceptance=float(np.mean(sampler.acceptance_fraction)),
                 n_steps=sampler.iteration, burn=burn, thin=thin, converged=converged,
                 mode=mode)


def _burn_and_thin(tau: NDArray, n_steps: int) -> tuple[int, int]:
    """Discard 3 τ_max (at most half the chain); thin by τ_min / 2."""
    finite = np.isfinite(tau)
    tau_max = float(np.max(tau[finite])) if finite.any() else n_steps / 10
    tau_min = float(np.min(tau[finite])) if finite.any() else 1.0
    return min(math.ceil(3 * tau_max), n_steps // 2), max(1, int(tau_min / 2))


def _targets_met(variables: dict[str, NDArray], settings: SamplerSettings) -> bool:
    """R-hat and bulk/tail ESS of every ``(walkers, draws)`` array meet the settings."""
    for draws in variables.values():
        if not (az.rhat(draws) < settings.max_r_hat
                and az.ess(draws, method="bulk") >= settings.min_ess
                and az.ess(draws, method="tail") >= settings.min_ess):
            return False
    return True
