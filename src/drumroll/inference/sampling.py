"""Ensemble MCMC (differential-evolution moves) until every reported quantity is known to
its targets: bulk and tail ESS and R-hat.

emcee's :class:`~emcee.EnsembleSampler` moves the walkers by red-blue differential evolution
(ter Braak 2006; Nelson et al. 2013), each half-ensemble one batched call of the target, in
the sampler coordinates of :mod:`~drumroll.inference.coordinates`; the run goes on in chunks
until the draws it would report meet the targets.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, special

from drumroll.errors import OnsetsOutsidePriors
from drumroll.inference.convergence import diagnose, integrated_time
from drumroll.inference.coordinates import AtomGeometry, SamplerCoordinates
from drumroll.inference.laplace import laplace
from drumroll.inference.lockstep import lockstep
from drumroll.inference.posterior import LogPosterior

#: Draws ``(walkers, draws, ndim)`` → every reported quantity, ``(walkers, draws)`` each.
Reported = Callable[[NDArray], dict[str, NDArray]]


@dataclass(frozen=True)
class SamplerSettings:
    """The ``[sampler]`` section.

    Attributes
    ----------
    walkers
        Number of walkers (at least 2 × ndim + 2; raised when smaller).
    max_steps
        Stop here even if the targets are not met (a diagnostic then says so).
    target_ess, max_r_hat
        The run goes on until every reported quantity (the sampled parameters, and whatever
        ``run_emcee``'s ``reported`` adds: derived quantities, T0) has bulk and tail ESS of
        at least ``target_ess`` (walkers as chains) and a rank-normalised split R-hat below
        ``max_r_hat`` (walkers in groups as chains: :mod:`~drumroll.inference.convergence`).
        The check is made on exactly the draws that are reported, so the report meets these
        targets whenever the run converged.
    tau_multiple
        Fewest autocorrelation times (τ_max) in a converged chain: a floor that keeps the
        burn-in (3 τ) a small part of the chain and τ itself estimated from many τ's. ESS ≥
        1,000 over 32 walkers already needs ~30 τ, so at the defaults it rarely binds.
    seed
        Seed of everything random in the run.
    check_every
        Steps before the first convergence check. Later checks come where the ESS seen so far
        says the targets will be met (ESS grows in proportion to the steps after burn-in),
        at most twice as far as the last one: three or four checks a run.
    """

    walkers: int = 128
    max_steps: int = 20_000
    target_ess: float = 1000.0
    max_r_hat: float = 1.01
    tau_multiple: float = 20.0
    seed: int = 0
    check_every: int = 250


@dataclass(frozen=True)
class Chain:
    """A finished run, burn-in discarded and thinned.

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
        Whether every reported quantity met the targets before ``max_steps``.
    mode
        The point the walkers started around (the highest density found in z).
    checks
        Convergence checks made.
    atoms
        The sampler coordinates' geometry of effects that may be absent (see
        :class:`~drumroll.inference.coordinates.SamplerCoordinates`): where the posterior,
        in them, is compact (the evidence's importance sampling uses them too).
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
    checks: int = 0
    atoms: tuple[AtomGeometry, ...] = ()


def initial_ball(log_posterior: LogPosterior, centre: NDArray, walkers: int,
                 rng: np.random.Generator) -> NDArray:
    """Walkers in a small ball around ``centre``, each inside the posterior's typical set.

    The ball's width starts at 1e-4 of each prior's spread, which is small only where the
    prior is not much wider than the posterior: with t_B ~ U(0.01, 20) s it put walkers tens
    of posterior sds out (80 nats below the mode), and some were still walking in after a
    burn-in of 3 τ, their draws kept (PSIS-LOO then flagged 12 of 15 onsets of table2_h50).
    Each walker is then pulled into the typical set (:func:`_pulled_in`). Runs start so only
    where Laplace's method has no Gaussian to offer (:func:`laplace_ball`)."""
    prior_spread = np.std(log_posterior.space.sample_prior(rng, 4000), axis=0)
    width = np.where(prior_spread > 0, 1e-4 * prior_spread, 1e-8)
    return _pulled_in(log_posterior, centre,
                      centre + width * rng.standard_normal((walkers, centre.size)))


def laplace_ball(target: SamplerTarget, centre: NDArray, walkers: int,
                 rng: np.random.Generator) -> NDArray | None:
    """Walkers drawn from the Gaussian Laplace's method fits at ``centre`` (z, the highest
    point found), each pulled into the typical set (:func:`_pulled_in`); None where there is
    no such Gaussian (−H not positive definite).

    From a ball of 1e-4 of the priors' spread the walkers take a hundred steps and more to
    spread out to the posterior's width (the affine-invariant and differential-evolution
    moves widen the ensemble by a factor per step, and 10⁴ is many factors), every one of
    them burn-in. Drawn from the posterior's own Gaussian they start at its width: on the
    README's roll, five seeds each, the exact pendulum's first walk with every effect present
    (:func:`_present_walk`) ended after two chunks, the fewest it takes (100 steps, against
    150), and the runs took a median of 600, 937 and 640 steps for the exact pendulum, the
    small-angle pendulum and the power law, against 697, 1014 and 708, the posteriors the same
    within their Monte Carlo error.

    Where the posterior is no Gaussian (a contact time piled against its slab's end) the
    Gaussian is wider than it along the columns that correlate with the edge's: α started 2.4
    times its posterior sd on a power-law roll whose contact is mostly absent. That is kept:
    walkers started wide fall back within a few steps, pulled by the density, while walkers
    started narrow only spread by a factor per step (and over-dispersed starts are what
    R-hat's comparison of walkers presumes). Drawing the other columns given the edge instead
    (the Gaussian's conditional) started α at 0.6-0.7 of its sd and took more steps: medians
    650, 992 and 633 against 600, 937 and 640. The pull into the typical set and the prior's
    support bound how wide."""
    estimate = laplace(target, centre, target.coordinates.bounds())
    if estimate.covariance is None:
        return None
    try:
        root = np.linalg.cholesky(estimate.covariance)
    except np.linalg.LinAlgError:
        return None
    return _pulled_in(target, centre, centre + rng.standard_normal((walkers, centre.size))
                      @ root.T)


def _pulled_in(density: Callable[[NDArray], NDArray], centre: NDArray, ball: NDArray
               ) -> NDArray:
    """``ball`` with each walker pulled halfway back to ``centre`` while its log ``density``
    lies further below the centre's than a Gaussian posterior's would in 99.9 % of draws
    (χ²_ndim / 2), or is −inf; a walker still outside after 100 halvings is put on the
    centre."""
    # χ²_ndim's 0.999 quantile over 2 (scipy.special: scipy.stats stays unimported at start-up).
    floor = float(density(centre[None])[0]) - special.gammaincinv(0.5 * centre.size, 0.999)
    for _ in range(100):
        values = density(ball)
        bad = ~np.isfinite(values) | (values < floor)
        if not bad.any():
            return ball
        ball[bad] = centre + 0.5 * (ball[bad] - centre)
    ball[~np.isfinite(density(ball))] = centre
    return ball


class SamplerTarget:
    """The log density the walkers sample: the posterior in :class:`SamplerCoordinates` z,
    log p(x(z)) + log |det ∂x/∂z| (a plain, picklable callable)."""

    def __init__(self, log_posterior: LogPosterior, coordinates: SamplerCoordinates) -> None:
        self.log_posterior = log_posterior
        self.coordinates = coordinates

    def __call__(self, z: NDArray) -> NDArray:
        return self.evaluate(z)[0]

    def evaluate(self, z: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """The density of each row of ``z``, its parameters x and their log posterior
        (−inf where invalid), so that the chain of parameters needs no second pass through
        the map."""
        x, log_det, impacts = self.coordinates.to_parameters_and_impacts(z)
        log_p = self.log_posterior(x) if impacts is None else self.log_posterior(x, impacts)
        with np.errstate(invalid="ignore"):  # −inf + inf: far outside, as invalid as it gets
            density = log_p + log_det
        if not np.isfinite(density).all():
            density[~np.isfinite(density)] = -np.inf
        return density, x, log_p


def find_start(target: SamplerTarget, rng: np.random.Generator, n_starts: int = 4,
               n_candidates: int = 10_000) -> NDArray:
    """The highest density found in sampler coordinates z, where the walkers start.

    The starts are the best of ``n_candidates`` prior draws (one vectorised call; a sampled
    T0 put at its best value given the rest, offset δ = 0), so a multimodal posterior is
    approached from several sides. From each start, L-BFGS-B climbs inside the priors' box
    (:meth:`SamplerCoordinates.bounds`) with finite-difference gradients, each gradient one
    batched call of 2 ndim + 1 points, in z scaled by the curvature at the start (restarted,
    re-scaled, while it stops short with progress still being made). In z the pendulum's
    curved (d, h) ridge is nearly straight, so a few dozen such calls reach the top, where
    Nelder–Mead in x took ~2,000 one-point calls per start and still stopped short on the
    ridge. The walkers only need to start near the bulk: burn-in does the rest.

    Four starts: over the ten bundled recordings, every model, 20 seeds each (560 searches),
    the best of four climbs ended more than 1 nat below the best ever found once (by 1.0
    nat); unbounded climbs from eight starts, which stalled on a prior's edge, ended hundreds
    of nats short on 8 of 20 seeds of the ping-pong roll.

    Returns
    -------
    NDArray
        The best point found, in z, shape ``(ndim,)``.
    """
    space = target.log_posterior.space
    z = target.coordinates.to_sampler(space.sample_prior(rng, n_candidates), t0_centred=True)
    density = target(z)
    finite = np.isfinite(density)
    if not finite.any():
        raise OnsetsOutsidePriors(space.model)
    z, density = z[finite], density[finite]
    spread = np.std(z, axis=0)
    spread = np.where(spread > 0, spread, 1.0)
    best, best_value = z[np.argmax(density)], float(np.max(density))
    starts = z[np.argsort(density)[::-1][:n_starts]]
    # The climbs side by side, their calls of the target batched (inference.lockstep: the
    # same points and values as one climb after another, for about 3/4 of the time).
    climbs = lockstep(target, [partial(climb, start=start, spread=spread)
                               for start in starts])
    for point, value in climbs:
        if value > best_value:
            best, best_value = point, value
    return best


#: The atoms' plateau in sds of the effect's size given that it is present
#: (:func:`atom_geometry`). Steps to convergence, three seeds each: table2_h80's small-angle
#: fit (P(no contact) = 0.9, contact 0-1 ms) took 1649, 1202, 1188 at 2 sds, 998, 1130, 1120
#: at 8 and 1141, 856, 1045 at the prior's 3 ms; its power law 744, 854, 685 / 687, 694, 766 /
#: 646, 744, 620; on a simulated roll timed to 5 µs (the contact slab 15-90 µs wide) the
#: pendulum took 3813, 1720, 1012 / 919, 883, 821 / 2751, 1863, 1070 and the power law 685,
#: 739, 762 / 769, 791, 650 / 750, 854, 799. Posteriors, P(absent) and ln Z agreed within
#: their Monte Carlo error throughout.
PLATEAU_SDS = 8.0


def atom_geometry(coordinates: SamplerCoordinates, slab_draws: NDArray
                  ) -> tuple[AtomGeometry, ...]:
    """How the walkers should move between "absent" and "present" for each atom column of
    ``coordinates`` (:class:`~drumroll.inference.coordinates.AtomGeometry`, one per
    :attr:`~drumroll.inference.coordinates.SamplerCoordinates.atom_columns`), from draws of
    the posterior with every effect present (z ``(..., ndim)`` in ``coordinates``, the atoms'
    columns ≥ 0: :func:`run_emcee`'s first steps).

    Along atom column j, with τ the effect's size and θ the other columns:

    * the ridge: b_θ = cov(θ, τ) / var(τ), how far the other columns' mean moves per unit of
      the effect (a contact time is taken up by the flights);
    * the plateau: :data:`PLATEAU_SDS` times τ's sd, never wider than the prior's own
      plateau (the prior's own where τ does not vary). The prior's own plateau makes the
      density of z continuous at 0 (the likelihood is continuous there), but walkers spread
      over 3 ms cross it slowly when the slab is tens of µs wide; a plateau a few slab sds
      wide is crossed quickly, and "absent" is then denser in z than "present" next to it
      by width / plateau, which walkers entering the slab must climb down.

    Taken from draws, not from derivatives at the start: the posterior of a contact time that
    piles against 0 is far from Gaussian there (a roll of 16 onsets timed to 10 µs: the
    curvature at 0 put the half-nat point at 16 µs, while the draws reach 0.3 ms).
    """
    z = np.asarray(slab_draws, float).reshape(-1, slab_draws.shape[-1])
    z = z[np.all(np.isfinite(z), axis=1)]
    space = coordinates.space
    out = []
    for j in coordinates.atom_columns:
        width = space.priors[space.names[j]].width
        size = z[:, j]
        spread = float(np.std(size)) if size.size > 1 else 0.0
        if not spread > 0.0:
            out.append(AtomGeometry(width))
            continue
        ridge = ((z - z.mean(axis=0)).T @ (size - size.mean())) / (size.size * spread**2)
        ridge[list(coordinates.atom_columns)] = 0.0  # each atom keeps its own column
        out.append(AtomGeometry(min(PLATEAU_SDS * spread, width),
                                tuple(float(v) for v in ridge)))
    return tuple(out)


class _SlabTarget:
    """``target`` with every effect that may be absent present: −inf where an atom's column
    is below 0 (the plateau). Above 0 an atom's density is its slab's times 1 − p₀, a
    constant, so this is the posterior given that every effect is present."""

    def __init__(self, target: SamplerTarget) -> None:
        self.target = target
        self.columns = list(target.coordinates.atom_columns)

    def __call__(self, z: NDArray) -> NDArray:
        density = self.target(z)
        density[np.any(z[:, self.columns] < 0.0, axis=1)] = -np.inf
        return density


#: The first walk with every effect present (:func:`_present_walk`) goes in chunks of this
#: many steps, and ends once the walkers' spread has stopped growing: every column's sd over
#: the last chunk within this factor of the one before.
PRESENT_CHUNK, SPREAD_SETTLED = 50, 1.25


def _present_walk(target: SamplerTarget, start: NDArray, most: int, seed: int
                  ) -> tuple[SamplerCoordinates, NDArray, int]:
    """Walk from ``start`` (z, ``(walkers, ndim)``) with every effect that may be absent
    present (:class:`_SlabTarget`), until the walkers' spread has settled to the
    posterior's (or for ``most`` steps); the last two chunks show how the
    posterior moves with each effect's size (:func:`atom_geometry`). Returns the coordinates
    with that geometry, where the walkers ended (as parameters x) and the steps taken.

    The spread decides when, rather than a fixed number of steps: from a ball of 10⁻⁴ of the
    priors' spread (:func:`initial_ball`) the walkers of the exact pendulum on the README's
    roll reach their posterior's spread in about 150 steps, those of the small-angle model,
    whose contact time piles against 0, in about 250; from the Laplace Gaussian
    (:func:`laplace_ball`) in 100 and 150-250. A geometry taken too early, from walkers still
    spreading, is too narrow, and the run after it mixed ten times more slowly.
    """
    coordinates = target.coordinates
    start = start.copy()
    start[:, coordinates.atom_columns] = np.abs(start[:, coordinates.atom_columns])
    walk = ensemble_sampler(_SlabTarget(target), start.shape[0], start.shape[1], seed)
    state, steps, before = start, 0, None
    while steps < most:
        state = walk.run_mcmc(state, min(PRESENT_CHUNK, most - steps), progress=False)
        steps = walk.iteration
        spread = np.std(walk.get_chain(discard=max(steps - PRESENT_CHUNK, 0)), axis=(0, 1))
        with np.errstate(divide="ignore", invalid="ignore"):
            settled = (before is not None
                       and np.all(np.abs(np.log(spread / before)) < math.log(SPREAD_SETTLED)))
        if settled:
            break
        before = spread
    present = coordinates.to_parameters(walk.get_last_sample().coords)[0]
    geometry = atom_geometry(coordinates, walk.get_chain(discard=max(steps - 2 * PRESENT_CHUNK,
                                                                     steps // 2)))
    return replace(coordinates, atoms=geometry), present, steps


def sampler_coordinates(log_posterior: LogPosterior, settings: SamplerSettings
                        ) -> SamplerCoordinates:
    """The coordinates :func:`run_emcee` samples ``log_posterior`` in with ``settings``,
    the geometry of its effects that may be absent included (its start search and first walk
    with them present, as the run makes them): for a sampler of several posteriors at once (a
    joint fit, :mod:`drumroll.table.joint`), whose own run sees none of their atoms."""
    target, _, start = _start(log_posterior, settings)
    if not target.coordinates.atom_columns:
        return target.coordinates
    return _first_walk(target, start, settings)[0]


def _start(log_posterior: LogPosterior, settings: SamplerSettings
           ) -> tuple[SamplerTarget, NDArray, NDArray]:
    """Where a run of ``settings`` starts: its target in the plain sampler coordinates, the
    highest point found (:func:`find_start`, as parameters x) and the walkers drawn around it
    (:func:`laplace_ball`, else :func:`initial_ball`; in z)."""
    rng = np.random.default_rng(settings.seed)
    walkers = max(settings.walkers, 2 * log_posterior.space.ndim + 2)
    coordinates = SamplerCoordinates(log_posterior.space, getattr(log_posterior, "data", None))
    target = SamplerTarget(log_posterior, coordinates)
    highest = find_start(target, rng)
    mode = coordinates.to_parameters(highest[None])[0][0]
    start = laplace_ball(target, highest, walkers, rng)
    if start is None:
        start = coordinates.to_sampler(initial_ball(log_posterior, mode, walkers, rng))
    return target, mode, start


def _walk_seeds(settings: SamplerSettings) -> tuple[int, int]:
    """The seeds of a run's kept chain and of its first walk with every effect present."""
    seeds = np.random.SeedSequence([settings.seed, 1]).generate_state(2)
    return int(seeds[0]), int(seeds[1])


def _first_walk(target: SamplerTarget, start: NDArray, settings: SamplerSettings
                ) -> tuple[SamplerCoordinates, NDArray, int]:
    """:func:`_present_walk` as a run of ``settings`` makes it: at most one check's worth of
    steps (and half the step limit), from its own seed."""
    return _present_walk(target, start, min(settings.check_every, settings.max_steps // 2),
                         _walk_seeds(settings)[1])


def climb(target: SamplerTarget, start: NDArray, spread: NDArray, attempts: int = 6
           ) -> tuple[NDArray, float]:
    """L-BFGS-B from ``start`` inside the priors' box (see :func:`find_start`): the point
    reached and its density.

    The box matters: the density is −inf past a prior's edge, and unbounded BFGS, on its way
    up, ran onto such edges (the contact time at 0, the jitter at an end of its range), where
    a central difference has no value on one side. A zero gradient there stopped the climb
    hundreds of nats below the top (8 of 20 seeds on the ping-pong roll); within the box the
    gradient is one-sided on a bound and projected, and the climb goes on along it."""
    ndim = start.size
    box = target.coordinates.bounds()
    point, value = start, -math.inf
    for _ in range(attempts):
        h = 1e-4 * spread
        around = target(point + np.concatenate([np.zeros((1, ndim)), np.diag(h), -np.diag(h)]))
        with np.errstate(invalid="ignore", divide="ignore"):
            curvature = (around[1:ndim + 1] + around[ndim + 1:] - 2.0 * around[0]) / h**2
            scale = np.where(np.isfinite(curvature) & (curvature < 0),
                             np.minimum(1.0 / np.sqrt(np.abs(curvature)), spread), spread)
        bounds = [(None if not np.isfinite(lo) else lo / s, None if not np.isfinite(hi) else hi / s)
                  for (lo, hi), s in zip(box, scale, strict=True)]
        result = optimize.minimize(_negative_with_gradient(target, scale), point / scale,
                                   jac=True, method="L-BFGS-B", bounds=bounds,
                                   options={"maxiter": 200, "gtol": 1e-3})
        if not result.fun < 1e10:
            break
        gain = -float(result.fun) - value
        point, value = result.x * scale, -float(result.fun)
        if result.success or gain < 1e-2:
            break
    return point, value


def _negative_with_gradient(target: SamplerTarget, scale: NDArray
                            ) -> Callable[[NDArray], tuple[float, NDArray]]:
    """−density and its finite-difference gradient at u = z / scale, in one batched call:
    central differences, one-sided where a step crosses an edge of the allowed region (a
    prior's bound: the climb stays inside, so the other side is there). A forbidden point
    costs 1e10 (finite, so the line search backs off from it)."""
    ndim = scale.size
    step = 1e-5
    offsets = np.concatenate([np.zeros((1, ndim)), step * np.eye(ndim), -step * np.eye(ndim)])

    def negative(u: NDArray) -> tuple[float, NDArray]:
        values = target((u + offsets) * scale)
        centre, up, down = values[0], values[1:ndim + 1], values[ndim + 1:]
        if not np.isfinite(centre):
            return 1e10, np.zeros(ndim)
        with np.errstate(invalid="ignore"):
            gradient = np.where(np.isfinite(up) & np.isfinite(down), (up - down) / (2.0 * step),
                                np.where(np.isfinite(up), (up - centre) / step,
                                         np.where(np.isfinite(down), (centre - down) / step,
                                                  0.0)))
        return -float(centre), -gradient

    return negative


#: The moves (emcee's :class:`~emcee.moves.DEMove`): differential evolution with the optimal
#: scale γ = 2.38 / sqrt(2 ndim) and, one step in ten (:data:`JUMP_PROBABILITY`), γ = 1, which
#: jumps between modes (ter Braak 2006). emcee 3.1.6's DESnookerMove normalises its direction
#: by sqrt(|δ|) instead of |δ| and halves the Jacobian term, so it does not keep the target
#: invariant (on a 6-d Gaussian alone it shrinks the variances by ~30 %; dfm/emcee#531); it is
#: not used.
JUMP_PROBABILITY = 0.1
#: Where effects may be absent (atoms at 0), one step in ten is instead each walker's mirror
#: image across 0 in one such column (:class:`~drumroll.inference.ensemble.AtomReflectMove`),
#: which moves walkers between "absent" and "present" directly. Where that mixing limits a run
#: it cuts the steps: the README roll's small-angle model 1554 and 988 → 1076 and 830 (seeds 0
#: and 1; the contact time's τ 37 → 26 steps), push.flac's exact pendulum a mean 4562 → 2573
#: (six seeds); over the 200 rolls of ``drumroll calibrate data/table2_h80.toml``, 12 % fewer
#: steps where the truth has no contact, 5 % more where it has one (the tenth of the steps it
#: takes), 4 % fewer in all. P(absent) and every mean and sd are unchanged within their Monte
#: Carlo error (six seeds at ESS 6000 each way on the README roll).
REFLECT_PROBABILITY = 0.1


def moves(atom_columns: tuple[int, ...] = ()) -> list:
    """emcee's red-blue differential-evolution moves with their weights (see above), their
    acceptance step vectorised (:mod:`~drumroll.inference.ensemble`: the same chain), and
    with ``atom_columns`` (columns of z that stand for an effect that may be absent) the
    reflection across 0 of :data:`REFLECT_PROBABILITY`."""
    from drumroll.inference.ensemble import AtomReflectMove, DEMove

    de = [(DEMove(), 1.0 - JUMP_PROBABILITY), (DEMove(gamma0=1.0), JUMP_PROBABILITY)]
    if not atom_columns:
        return de
    return [*((move, weight * (1.0 - REFLECT_PROBABILITY)) for move, weight in de),
            (AtomReflectMove(atom_columns), REFLECT_PROBABILITY)]


def ensemble_sampler(target: Callable[[NDArray], NDArray], walkers: int, ndim: int,
                     seed: int, atom_columns: tuple[int, ...] = ()):
    """An :class:`emcee.EnsembleSampler` of ``target`` (one batched call per half-ensemble;
    :class:`drumroll.inference.ensemble.EnsembleSampler`), seeded by ``seed`` and moved by
    :func:`moves` (with the reflection across 0 in ``atom_columns``)."""
    from drumroll.inference.ensemble import EnsembleSampler

    sampler = EnsembleSampler(walkers, ndim, target, moves=moves(atom_columns), vectorize=True)
    sampler.random_state = np.random.RandomState(seed).get_state()  # emcee draws from a RandomState
    return sampler


def run_emcee(log_posterior: LogPosterior, settings: SamplerSettings,
              progress: Callable[[int, int], None] | None = None,
              reported: Reported | None = None) -> Chain:
    """Sample until every reported quantity meets the ESS and R-hat targets of ``settings``.

    The walkers move in :class:`~drumroll.inference.coordinates.SamplerCoordinates` (h through q
    = ω_C/γ, the jitter and t_B through their logarithms, a sampled T0 through its non-centred
    offset), where the posterior is nearly Gaussian: with the differential-evolution moves of
    :func:`moves` the autocorrelation time falls from ~90 to ~25–40 steps. Every diagnostic (τ,
    R-hat, ESS) and every output is computed on the model's own parameters. The walkers start
    drawn from the Gaussian Laplace's method fits at the highest point found
    (:func:`find_start`, :func:`laplace_ball`). Where an effect may be absent (an atom at 0, the
    default contact time), they first walk with it present (:func:`_present_walk`: until the
    walkers' spread settles, at most one check's worth of steps), whose draws set the
    coordinates in which "absent" and "present" mix (:func:`atom_geometry`); those steps are
    burn-in, counted in ``n_steps`` and ``burn``. At each check ``3 τ_max`` steps are discarded
    as burn-in and the rest thinned by ``τ_min / 3`` (which costs a few percent of ESS); the
    targets are checked on exactly these draws, and the run stops at the first check that meets
    them.

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
    target, mode, start = _start(log_posterior, settings)
    coordinates = target.coordinates
    walkers, ndim = start.shape
    # The walk itself, past the start's climb, in |z| for the scatter (SamplerCoordinates).
    folded = replace(coordinates, fold_scatter=True)
    if folded.folded_columns:
        start = folded.to_sampler(coordinates.to_parameters(start)[0])
        coordinates, target = folded, SamplerTarget(log_posterior, folded)
    from drumroll.inference.ensemble import emcee  # emcee without scipy.stats

    if not emcee.ensemble.walkers_independent(start):  # emcee's own test, run_mcmc's first
        # The ball fell onto its centre: no walker a hair from the best point keeps a density
        # a Gaussian posterior would give it, which onsets a model can fit never do (times in
        # the wrong unit, a jitter prior that stops short of the roll's misfit).
        raise OnsetsOutsidePriors(log_posterior.space.model)
    first = 0  # steps taken before the chain that is kept (the atoms' first phase)
    if coordinates.atom_columns:
        # Effects that may be absent: a first walk with every effect present sets the
        # coordinates that let "absent" and "present" mix; its steps are burn-in.
        coordinates, present, first = _first_walk(target, start, settings)
        target = SamplerTarget(log_posterior, coordinates)
        start = coordinates.to_sampler(present)
        if progress is not None:
            progress(first, settings.max_steps)
    sampler = ensemble_sampler(target, walkers, ndim, _walk_seeds(settings)[0],
                               coordinates.atom_columns)
    converged, checks, steps, state = False, 0, 0, start
    until = min(settings.check_every, settings.max_steps - first)
    while True:
        state = sampler.run_mcmc(state, until - steps, progress=False)
        steps = until
        checks += 1
        if progress is not None:
            progress(first + steps, settings.max_steps)
        # τ of the walk in z, where it moves: burn-in and thinning are about its mixing.
        tau = integrated_time(sampler.get_chain())
        burn, thin = _burn_and_thin(tau, steps)
        samples, log_prob = parameter_draws(sampler, coordinates, burn, thin)
        # The sampled parameters first: the reported quantities (derived ones, T0 drawn
        # given the rest) cost a forward model per draw, and are checked only once the
        # parameters they derive from are on target.
        stats = diagnose({str(i): samples[..., i] for i in range(ndim)})
        long_enough = steps >= settings.tau_multiple * np.nanmax(tau)
        if long_enough and _targets_met(stats, settings) and reported is not None:
            stats = diagnose(reported(samples))
        if long_enough and _targets_met(stats, settings):
            converged = True
            break
        if first + steps >= settings.max_steps:
            break
        until = min(_next_check(stats, settings, tau, steps, burn), settings.max_steps - first)
    return Chain(samples=samples, log_prob=log_prob, tau=tau,
                 acceptance=float(np.mean(sampler.acceptance_fraction)),
                 n_steps=first + steps, burn=first + burn, thin=thin, converged=converged,
                 mode=mode, checks=checks, atoms=coordinates.atoms)


def parameter_draws(sampler, coordinates: SamplerCoordinates, burn: int, thin: int
                    ) -> tuple[NDArray, NDArray]:
    """The walkers' draws after ``burn`` steps, every ``thin``-th (the last kept), as the
    model's parameters x ``(walkers, draws, ndim)`` and their log posterior ``(walkers,
    draws)`` (the density in z less the map's log Jacobian)."""
    z = sampler.get_chain(discard=burn, thin=thin)
    density = sampler.get_log_prob(discard=burn, thin=thin)
    steps, walkers, ndim = z.shape
    x, log_det = coordinates.to_parameters(z.reshape(-1, ndim))
    log_p = density - log_det.reshape(steps, walkers)
    return np.swapaxes(x.reshape(steps, walkers, ndim), 0, 1), log_p.T


def _burn_and_thin(tau: NDArray, n_steps: int) -> tuple[int, int]:
    """Discard 3 τ_max (at most half the chain); thin by τ_min / 3."""
    finite = np.isfinite(tau)
    tau_max = float(np.max(tau[finite])) if finite.any() else n_steps / 10
    tau_min = float(np.min(tau[finite])) if finite.any() else 1.0
    return min(math.ceil(3 * tau_max), n_steps // 2), max(1, int(tau_min / 3))


def _targets_met(stats: dict[str, dict[str, float]], settings: SamplerSettings) -> bool:
    """Every quantity's R-hat and bulk/tail ESS meet the settings (NaN never does)."""
    return all(s["r_hat"] < settings.max_r_hat and s["ess_bulk"] >= settings.target_ess
               and s["ess_tail"] >= settings.target_ess for s in stats.values())


def _next_check(stats: dict[str, dict[str, float]], settings: SamplerSettings, tau: NDArray,
                steps: int, burn: int) -> int:
    """Where the next check should find the targets met: ESS grows in proportion to the
    steps kept, so the worst quantity's shortfall says how much longer to run (with a tenth
    to spare, so that one more check usually suffices); never less than a tenth further, at
    most twice as far."""
    worst = min((min(s["ess_bulk"], s["ess_tail"]) for s in stats.values()), default=math.nan)
    if math.isfinite(worst) and worst > 0:
        wanted = burn + 1.1 * (steps - burn) * settings.target_ess / worst
    else:
        wanted = 2.0 * steps
    if np.isfinite(tau).any():
        wanted = max(wanted, 1.05 * settings.tau_multiple * float(np.nanmax(tau)))
    return int(min(max(math.ceil(wanted), steps + max(steps // 10, 10)), 2 * steps))
