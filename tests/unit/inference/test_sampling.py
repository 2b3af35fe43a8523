"""The sampler's own loop and its stopping rule: ESS and R-hat equal ArviZ's, τ equals emcee's,
the moves keep a known target invariant, and a run stops with every reported quantity on
target."""

from __future__ import annotations

import math
import subprocess
import sys

import arviz as az
import emcee
import numpy as np
import pytest

from drumroll.config import parse_config
from drumroll.inference import convergence
from drumroll.inference.likelihood import OnsetData
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.sampling import SamplerSettings, ensemble_sampler, run_emcee
from drumroll.pipeline import reported_draws


def _autocorrelated(rng: np.random.Generator, shape: tuple[int, ...], rho: float) -> np.ndarray:
    """AR(1) draws along the last axis (τ = (1 + ρ) / (1 − ρ))."""
    noise = rng.standard_normal(shape)
    out = np.empty(shape)
    out[..., 0] = noise[..., 0]
    for t in range(1, shape[-1]):
        out[..., t] = rho * out[..., t - 1] + math.sqrt(1 - rho * rho) * noise[..., t]
    return out


@pytest.mark.parametrize("shape", [(32, 85), (64, 301), (4, 1000), (7, 9)])
def test_ess_and_r_hat_equal_arviz(shape):
    rng = np.random.default_rng(sum(shape))
    draws = _autocorrelated(rng, (4, *shape), 0.6)
    draws[1] = np.round(draws[1], 1)  # ties in the ranks
    draws[2] = np.exp(draws[2])  # skewed
    draws[3, :2] += 1.5  # two walkers elsewhere: R-hat must see it
    stats = convergence.diagnose({str(i): draws[i] for i in range(4)})
    for i in range(4):
        got = stats[str(i)]
        assert got["ess_bulk"] == pytest.approx(az.ess(draws[i], method="bulk"), rel=1e-9)
        assert got["ess_tail"] == pytest.approx(az.ess(draws[i], method="tail"), rel=1e-9)
        grouped = convergence.grouped(draws[i][None])[0]
        assert got["r_hat"] == pytest.approx(az.rhat(grouped), rel=1e-12)


def test_grouped_r_hat_sees_disagreement_not_length():
    """Well-mixed walkers: R-hat over groups is near 1 at ESS ~1,000, where R-hat over the 64
    walkers as chains is ~sqrt(1 + 128 / ESS); walkers that disagree push it over 1.01."""
    rng = np.random.default_rng(3)
    draws = _autocorrelated(rng, (64, 400), 0.9)
    stats = convergence.diagnose({"x": draws})["x"]
    assert 500 < stats["ess_bulk"] < 2000
    assert stats["r_hat"] < 1.01 < az.rhat(draws)
    shifted = draws.copy()
    shifted[:16] += 0.5  # one group of walkers off by half a posterior sd
    assert convergence.diagnose({"x": shifted})["x"]["r_hat"] > 1.01


def test_integrated_time_equals_emcee():
    rng = np.random.default_rng(5)
    chain = np.moveaxis(_autocorrelated(rng, (3, 32, 2000), 0.95), -1, 0)  # (steps, walkers, 3)
    chain = np.swapaxes(chain, 1, 2)
    np.testing.assert_allclose(convergence.integrated_time(chain),
                               emcee.autocorr.integrated_time(chain, tol=0), rtol=1e-10)


def test_moves_keep_a_correlated_gaussian_invariant():
    """emcee with our moves (DE, one jump in ten) on a 4-d Gaussian (correlations 0.9, scales
    1e-3 … 10): means and covariances within their Monte Carlo error."""
    rng = np.random.default_rng(7)
    scales = np.array([1e-3, 0.1, 1.0, 10.0])
    corr = 0.9 * np.ones((4, 4)) + 0.1 * np.eye(4)
    cov = corr * np.outer(scales, scales)
    precision = np.linalg.inv(cov)
    mean = np.array([1.0, -2.0, 0.5, 3.0])

    def target(z):
        d = z - mean
        return -0.5 * np.einsum("ij,jk,ik->i", d, precision, d)

    sampler = ensemble_sampler(target, 32, 4, seed=8)
    sampler.run_mcmc(rng.multivariate_normal(mean, cov, 32), 3000)
    samples = np.swapaxes(sampler.get_chain(discard=200, thin=5), 0, 1)
    assert samples.shape == (32, 560, 4)
    flat = samples.reshape(-1, 4)
    np.testing.assert_allclose(sampler.get_log_prob(discard=200, thin=5).T.ravel(), target(flat))
    ess = convergence.diagnose({str(i): samples[..., i] for i in range(4)})
    n_eff = min(s["ess_bulk"] for s in ess.values())
    assert n_eff > 1000
    np.testing.assert_array_less(np.abs(flat.mean(0) - mean), 4 * scales / math.sqrt(n_eff))
    np.testing.assert_array_less(np.abs(flat.std(0) / scales - 1), 4 / math.sqrt(n_eff))
    np.testing.assert_allclose(np.corrcoef(flat.T), corr, atol=0.03)


def test_reflection_keeps_an_atom_and_its_slab_in_proportion():
    """An effect that may be absent, in sampler coordinates (column 0: a plateau [−2, 0) of
    mass 0.3 for "absent", a half-normal slab of mass 0.7 for its size; columns 1 and 2 a
    correlated Gaussian that does not care): sampled with the reflection across 0 among the
    moves, the share of draws on the plateau is 0.3 and the slab's mean √(2/π), within their
    Monte Carlo errors, and the other columns keep their Gaussian."""
    p_absent, plateau = 0.3, 2.0
    cov = np.array([[1.0, 0.8], [0.8, 1.0]])
    precision = np.linalg.inv(cov)

    def target(z):
        atom = np.where(z[:, 0] < 0.0,
                        np.where(z[:, 0] >= -plateau, math.log(p_absent / plateau), -np.inf),
                        math.log((1.0 - p_absent) * 2.0 / math.sqrt(2.0 * math.pi))
                        - 0.5 * z[:, 0] ** 2)
        rest = z[:, 1:]
        return atom - 0.5 * np.einsum("ij,jk,ik->i", rest, precision, rest)

    rng = np.random.default_rng(3)
    sampler = ensemble_sampler(target, 32, 3, seed=5, atom_columns=(0,))
    start = np.column_stack([rng.uniform(0.1, 1.0, 32), rng.multivariate_normal([0, 0], cov, 32)])
    sampler.run_mcmc(start, 4000)
    samples = np.swapaxes(sampler.get_chain(discard=300, thin=5), 0, 1)
    absent = (samples[..., 0] < 0.0).astype(float)
    stats = convergence.diagnose({"absent": absent, "z1": samples[..., 1]})
    n_eff = min(s["ess_bulk"] for s in stats.values())
    assert n_eff > 1000
    share = absent.mean()
    assert abs(share - p_absent) < 4 * math.sqrt(p_absent * (1 - p_absent) / n_eff)
    slab = samples[..., 0][samples[..., 0] >= 0.0]
    assert abs(slab.mean() - math.sqrt(2 / math.pi)) < 4 * 0.6 / math.sqrt(n_eff * (1 - share))
    rest = samples[..., 1:].reshape(-1, 2)
    np.testing.assert_allclose(np.cov(rest.T), cov, atol=0.1)


def test_a_scale_walked_as_its_absolute_value_is_sampled_exactly():
    """A scale parameter walked as |z| (column 0: s half-normal, piled against 0 as a
    restitution that may not scatter is; column 1: y ~ N(s, 0.5²), correlated with it), as
    :func:`run_emcee` walks the scatter: the density of z is the posterior's mirrored across
    0, and the draws' |z| have E[s] = √(2/π), E[s²] = 1, E[y] = E[s] and
    Var(y) = 0.25 + 1 − 2/π within their Monte Carlo errors. (Folding each proposal back onto
    z ≥ 0 instead, a reflecting wall, is not symmetric once s correlates with another column:
    it gave E[s] = 0.729 here.)"""

    def target(z):
        s = np.abs(z[:, 0])
        return -0.5 * s**2 - 0.5 * (z[:, 1] - s) ** 2 / 0.25

    rng = np.random.default_rng(11)
    sampler = ensemble_sampler(target, 32, 2, seed=12)
    start = np.column_stack([rng.uniform(0.0, 1.0, 32), rng.normal(0.5, 0.5, 32)])
    sampler.run_mcmc(start, 4000)
    samples = np.swapaxes(sampler.get_chain(discard=300, thin=5), 0, 1)
    assert np.mean(samples[..., 0] < 0.0) > 0.3  # the walkers cross 0: both sides are used
    samples[..., 0] = np.abs(samples[..., 0])
    stats = convergence.diagnose({"s": samples[..., 0], "s2": samples[..., 0] ** 2,
                                  "y": samples[..., 1]})
    n_eff = min(v["ess_bulk"] for v in stats.values())
    assert n_eff > 1000
    s, y = samples[..., 0].ravel(), samples[..., 1].ravel()
    var_s = 1.0 - 2.0 / math.pi
    assert abs(s.mean() - math.sqrt(2.0 / math.pi)) < 4 * math.sqrt(var_s / n_eff)
    assert abs(np.mean(s**2) - 1.0) < 4 * math.sqrt(2.0 / n_eff)  # Var(s²) = E s⁴ − 1 = 2
    assert abs(y.mean() - math.sqrt(2.0 / math.pi)) < 4 * math.sqrt((0.25 + var_s) / n_eff)
    assert abs(y.var() / (0.25 + var_s) - 1.0) < 4 * math.sqrt(2.0 / n_eff)


def test_lean_sampler_gives_emcee_s_own_chain():
    """The vectorised acceptance step and log-density bookkeeping
    (:mod:`drumroll.inference.ensemble`) draw emcee's random numbers in emcee's order: the
    chain equals that of emcee's own sampler and moves, number for number, rejections and
    forbidden points (−inf) included."""
    from drumroll.inference.sampling import JUMP_PROBABILITY

    def target(z):
        out = -0.5 * np.sum((z / [1.0, 0.1, 3.0]) ** 2, axis=1)
        return np.where(z[:, 0] > 1.5, -np.inf, out)  # a wall some walkers hit

    start = np.random.default_rng(3).normal(0.0, 0.1, (16, 3))
    ours = ensemble_sampler(target, 16, 3, seed=11)
    ours.run_mcmc(start, 300)
    theirs = emcee.EnsembleSampler(16, 3, target, vectorize=True, moves=[
        (emcee.moves.DEMove(), 1.0 - JUMP_PROBABILITY),
        (emcee.moves.DEMove(gamma0=1.0), JUMP_PROBABILITY)])
    theirs.random_state = np.random.RandomState(11).get_state()
    theirs.run_mcmc(start, 300)
    np.testing.assert_array_equal(ours.get_chain(), theirs.get_chain())
    np.testing.assert_array_equal(ours.get_log_prob(), theirs.get_log_prob())
    np.testing.assert_array_equal(ours.acceptance_fraction, theirs.acceptance_fraction)


def test_emcee_imported_without_scipy_stats_keeps_its_kde_move():
    """drumroll imports emcee with scipy.stats held back (its KDE move alone wants it); the
    KDE move still works, importing scipy.stats when it is first used."""
    code = ("import sys, numpy as np; from drumroll.inference.ensemble import emcee; "
            "assert 'scipy.stats' not in sys.modules; "
            "s = emcee.EnsembleSampler(16, 2, lambda x: -0.5 * np.sum(x**2), "
            "moves=emcee.moves.KDEMove()); s.run_mcmc(np.random.randn(16, 2), 10); "
            "assert 'scipy.stats' in sys.modules")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


POWERLAW = {"model": "powerlaw",
            "priors": {"alpha": {"dist": "uniform", "low": 0.5, "high": 1.0},
                       "t_b": {"dist": "uniform", "low": 0.01, "high": 2.0},
                       "jitter_ms": {"dist": "loguniform", "low": 0.01, "high": 10}}}


@pytest.fixture(scope="module")
def powerlaw_posterior():
    rng = np.random.default_rng(4)
    impacts = np.r_[0.0, np.cumsum(0.31 * 0.87 ** np.arange(1, 20))]
    data = OnsetData.from_arrays(0.5 + impacts + rng.normal(0, 3e-4, 20))
    return LogPosterior.build(parse_config(POWERLAW), "powerlaw", data)


def test_run_stops_when_every_reported_quantity_is_on_target(powerlaw_posterior):
    lp = powerlaw_posterior
    settings = SamplerSettings(seed=2, target_ess=2500)
    chain = run_emcee(lp, settings, reported=lambda d: reported_draws(lp, 2, d))
    assert chain.converged and chain.checks >= 2
    assert chain.n_steps >= settings.tau_multiple * np.max(chain.tau)
    assert chain.burn >= 3 * np.max(chain.tau) - 1
    reported = reported_draws(lp, 2, chain.samples)
    assert {"alpha", "t_b", "jitter_ms", "t0_s"} <= set(reported)
    for name, stats in convergence.diagnose(reported).items():
        assert stats["ess_bulk"] >= 2500 and stats["ess_tail"] >= 2500, name
        assert stats["r_hat"] < 1.01, name
    # Not far past the target either: the checks follow the ESS forecast.
    worst = min(min(s["ess_bulk"], s["ess_tail"]) for s in convergence.diagnose(reported).values())
    assert worst < 2 * 2500


def test_run_is_deterministic_given_the_seed(powerlaw_posterior):
    settings = SamplerSettings(seed=5, target_ess=300, walkers=16)
    first, second = run_emcee(powerlaw_posterior, settings), run_emcee(powerlaw_posterior,
                                                                       settings)
    np.testing.assert_array_equal(first.samples, second.samples)
    assert first.n_steps == second.n_steps


def test_step_limit_is_reported_as_not_converged(powerlaw_posterior):
    chain = run_emcee(powerlaw_posterior, SamplerSettings(seed=1, max_steps=300,
                                                          check_every=200, target_ess=20_000))
    assert not chain.converged and chain.n_steps == 300


def test_walkers_start_inside_the_posterior_however_wide_the_prior():
    """table2_h50's power law with t_B ~ U(0.01, 20) s: a ball 1e-4 of each prior's spread
    wide put walkers tens of posterior sds out in t_B (80 nats below the mode), and some were
    still walking in after burn-in, their draws kept. Every walker starts where a Gaussian
    posterior's draws lie 99.9 % of the time."""
    from scipy.stats import chi2

    from drumroll.inference.mode import find_mode
    from drumroll.inference.sampling import initial_ball

    wide = {**POWERLAW, "priors": {**POWERLAW["priors"],
                                   "t_b": {"dist": "uniform", "low": 0.01, "high": 20.0}}}
    rng = np.random.default_rng(4)
    impacts = np.r_[0.0, np.cumsum(0.2 * 0.9 ** np.arange(1, 16))]
    data = OnsetData.from_arrays(0.5 + impacts + rng.normal(0, 5e-5, 16))
    lp = LogPosterior.build(parse_config(wide), "powerlaw", data)
    centre = find_mode(lp, rng)
    ball = initial_ball(lp, centre, 64, rng)
    below = lp(centre[None])[0] - lp(ball)
    assert np.all(below <= 0.5 * chi2.ppf(0.999, centre.size) + 1e-9)
    assert np.all(np.std(ball, axis=0) > 0)  # still a ball: the moves need a spread


def test_walkers_start_at_the_posteriors_width():
    """The walkers drawn from the Laplace Gaussian at the highest point (laplace_ball) start
    spread as the posterior is, where the ball of 1e-4 of the priors' spread they replace
    took 100 steps and more of burn-in to grow: each column's sd between half and three times
    that of a long run of emcee's own stretch move on the same target (wider where the roll's
    contact time, mostly absent, piles against its slab's end and the Gaussian does not: an
    over-dispersed start, which the density pulls in), every column but the contact's own (an
    atom, no Gaussian's); every walker inside the typical set."""
    from scipy.stats import chi2

    from drumroll.inference.coordinates import SamplerCoordinates
    from drumroll.inference.sampling import SamplerTarget, find_start, laplace_ball

    rng = np.random.default_rng(4)
    impacts = np.r_[0.0, np.cumsum(0.31 * 0.87 ** np.arange(1, 20))]
    data = OnsetData.from_arrays(0.5 + impacts + rng.normal(0, 3e-4, 20))
    lp = LogPosterior.build(parse_config(POWERLAW), "powerlaw", data)
    coordinates = SamplerCoordinates(lp.space, lp.data)
    target = SamplerTarget(lp, coordinates)
    top = find_start(target, rng)
    ball = laplace_ball(target, top, 64, rng)
    assert ball is not None
    below = target(top[None])[0] - target(ball)
    assert np.all(below <= 0.5 * chi2.ppf(0.999, top.size) + 1e-9)
    reference = emcee.EnsembleSampler(64, top.size, target, vectorize=True)
    reference.random_state = np.random.RandomState(5).get_state()
    reference.run_mcmc(ball, 4000, progress=False)
    chain = reference.get_chain(discard=1000).reshape(-1, top.size)
    kept = [i for i in range(top.size) if i not in coordinates.atom_columns]
    ratio = np.std(ball, axis=0)[kept] / np.std(chain, axis=0)[kept]
    assert np.all((ratio > 0.5) & (ratio < 3.0)), ratio


def test_start_search_reaches_the_top_when_the_posterior_leans_on_a_prior_edge():
    """The ping-pong roll's power law: on the way up, the climbs cross regions where the
    contact time sits at 0 or the jitter at its prior's 10 ms, edges on which an unbounded
    climb stalled hundreds of nats short (8 of 20 seeds). Every seed's start must reach the
    top found by scipy's differential evolution over the same box (a global search of
    another kind)."""
    from scipy import optimize

    from drumroll.config import load_config
    from drumroll.inference.coordinates import SamplerCoordinates
    from drumroll.inference.sampling import SamplerTarget, find_start
    from drumroll.pipeline import choose_roll, load_onsets
    from tests.paths import DATA

    config = load_config(DATA / "pingpong.toml")
    data = choose_roll(load_onsets(DATA / "pingpong.wav"), None, "pingpong").data
    log_posterior = LogPosterior.build(config, "powerlaw", data, "gaussian")
    coordinates = SamplerCoordinates(log_posterior.space, log_posterior.data)
    target = SamplerTarget(log_posterior, coordinates)
    box = coordinates.bounds()
    box[~np.isfinite(box)] = np.nan
    reference = optimize.differential_evolution(
        lambda z: -np.nan_to_num(target(np.atleast_2d(z.T)), neginf=1e10), list(map(tuple, box)),
        seed=1, tol=1e-10, polish=False, vectorized=True, updating="deferred", maxiter=3000)
    top = -reference.fun
    reached = [float(target(find_start(target, np.random.default_rng(seed))[None])[0])
               for seed in range(10)]
    assert min(reached) > top - 0.1, (top, reached)
