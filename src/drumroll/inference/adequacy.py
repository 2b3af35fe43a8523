"""Does a fitted model describe the onsets? Posterior predictive checks of the residuals.

A model can fit a roll with small error bars and still be wrong: a ball whose restitution
falls with impact speed, fitted with a constant α, leaves residuals that are one smooth wave
(the real ping-pong of ``../shared/real``: neighbouring residuals correlate at 0.7), and the
error bars then describe the model, not the bouncer. Timing noise that the model explains
leaves residuals that are independent from one onset to the next. Three statistics of the
standardised residuals r_i = (t_i − μ_i(θ)) / s_i(θ), in time order, see the difference:

* the lag-1 autocorrelation, large when neighbouring residuals share a sign and a size;
* the number of runs of one sign (Wald and Wolfowitz 1940), small when they share a sign;
* the share of the residuals in the directions a restitution that scatters from bounce to
  bounce moves the onsets (:func:`scatter_walk`), once the directions the model's own
  parameters can follow are taken out: large when the onsets random-walk away from the fit
  as such a scatter makes them (:mod:`~drumroll.inference.scatter`).

Each is compared with its distribution under the model by the posterior predictive p-value
(Gelman, Meng and Stern 1996, "Posterior predictive assessment of model fitness via realized
discrepancies"): for every posterior draw θ, the statistic of the observed residuals against
that of residuals replicated from the model's own noise at θ,
p = Pr(T(r_rep; θ) ≥ T(r; θ) | data) (fewer runs, for the runs). A model whose p is below
:data:`LEVEL` in any check is flagged inadequate: with three checks, a model that is right is
flagged in at most 3 % of rolls (posterior predictive p-values are, if anything, conservative:
Meng 1994).

Why the third. A scatter of a few tenths of a percent leaves the constant-α fit's error bars
five to seven times too narrow (``benchmarks/scatter_coverage.py``), yet most of what it does
to the onsets the fitted α, t_B and contact time take up: the first two checks flagged 9 of 30
such power-law rolls of 16 onsets (0.2 % scatter). Its signature is known, though: the ε_j move
the onsets by G ε (G from :func:`~drumroll.inference.scatter.impact_sensitivity`), so the
locally most powerful statistic against it is the score of the scatter's variance at 0,
‖Gᵀ W r‖² against its expectation (Rao's score test of a variance component). Taken on the
residuals with the model's parameter directions projected out (the linearised model's
residual space, as a score test of a variance component on restricted residuals does), the
observed and the replicated residuals are compared like with like: the check flagged 12 of
those 30 rolls, the three together 14, and none of 200 rolls without scatter (0.5 % scatter:
12, 17 and the first two alone 12, of 30).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from drumroll.inference.inference_data import observed_onsets
from drumroll.inference.results import Adequacy, AdequacyCheck
from drumroll.inference.scatter import impact_sensitivity
from drumroll.inference.space import SCATTER

if TYPE_CHECKING:
    from drumroll.inference.posterior import LogPosterior

#: Posterior predictive p-value below which a check fails.
LEVEL = 0.01
#: Fewest onsets the checks need (three residuals make one lag-1 pair more than a mean).
MIN_ONSETS = 4
#: Most posterior draws (evenly spaced) the scatter check uses: its p-value to 1/500, which
#: is fine enough at :data:`LEVEL` and keeps the check to a few forward-model batches.
WALK_DRAWS = 500
#: Relative step of the finite differences that give the parameters' directions (of each
#: column's posterior sd): far above round-off in the onset times (~1e-16 s), far below the
#: posterior's curvature.
STEP = 1e-6
#: Columns that are not directions of the onsets' mean: the noise's own parameters, and T0
#: (the column of ones stands for it).
NOT_DIRECTIONS = frozenset({"jitter", SCATTER, "t0", "nu"})
#: Singular values of the weighted directions below this share of the largest are one
#: direction counted twice (a stick's geometry fixes t_B several ways).
RANK_TOLERANCE = 1e-9


def lag1_autocorrelation(residuals: NDArray) -> NDArray:
    """Lag-1 autocorrelation of each row of ``(draws, n)`` residuals (about the row's mean)."""
    centred = residuals - residuals.mean(axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (np.sum(centred[..., 1:] * centred[..., :-1], axis=-1)
                / np.sum(centred * centred, axis=-1))


def sign_runs(residuals: NDArray) -> NDArray:
    """Number of runs of one sign in each row of ``(draws, n)`` residuals (a zero counts as
    positive)."""
    positive = residuals >= 0.0
    return 1 + np.count_nonzero(positive[..., 1:] != positive[..., :-1], axis=-1)


def scatter_walk(residuals: NDArray, weights: NDArray, directions: NDArray,
                 sensitivity: NDArray) -> NDArray:
    """The scatter check's statistic per draw: how much more of the residuals lies in the
    directions a scattering restitution moves the onsets than independent noise would put
    there, once the model's parameter directions are projected out (1 for independent noise).

    With a = √w ⊙ r the standardised residuals, Q an orthonormal basis of the weighted
    parameter directions √w ⊙ J, P = I − Q Qᵀ and S = √w ⊙ G::

        T = (‖Sᵀ P a‖² / ‖P S‖²_F) / (‖P a‖² / (n − rank J)),

    whose two parts are each 1 in expectation when a is white noise.

    Parameters
    ----------
    residuals
        Onset times less the model's, ``(..., draws, n)`` (any offset common to a row is one
        of the directions when ``directions`` holds a column of ones): several sets at once
        (the observed and the replicated) share one projection.
    weights
        w = 1 / (jitter² + σ_i²), ``(draws, n)``.
    directions
        J = ∂μ/∂θ, ``(draws, n, p)``.
    sensitivity
        G = ∂τ/∂ε at the onsets, ``(draws, n, K)``.
    """
    root = np.sqrt(weights)
    u, singular, _ = np.linalg.svd(directions * root[..., None], full_matrices=False)
    keep = singular > RANK_TOLERANCE * singular[..., :1]
    basis = u * keep[:, None, :]
    a = residuals * root
    a = a - np.einsum("bnk,...bk->...bn", basis, np.einsum("bnk,...bn->...bk", basis, a))
    s = sensitivity * root[..., None]
    s = s - np.einsum("bnk,bkj->bnj", basis, np.einsum("bnk,bnj->bkj", basis, s))
    along = np.einsum("bnj,...bn->...bj", s, a)
    with np.errstate(divide="ignore", invalid="ignore"):
        return ((np.sum(along * along, axis=-1) / np.sum(s * s, axis=(1, 2)))
                / (np.sum(a * a, axis=-1) / (a.shape[-1] - keep.sum(axis=1))))


def scatter_check(log_posterior: LogPosterior, parameters: NDArray, noise: NDArray
                  ) -> AdequacyCheck | None:
    """The scatter check (:func:`scatter_walk`) of a fit: ``parameters`` ``(draws, ndim)``,
    the model's parameters draw by draw, and ``noise`` ``(draws, n)``, onsets replicated from
    the model's own noise less its onset times, at the same draws. Every
    :data:`WALK_DRAWS`-th draw or so is used; None when the model has nothing to move (no
    flight after the first onset) or no draw is valid."""
    data = log_posterior.data
    space = log_posterior.space
    x = np.asarray(parameters, float)
    if x.shape[0] == 0 or data.n_flights < 2:
        return None
    pick = np.unique(np.linspace(0, x.shape[0] - 1, min(WALK_DRAWS, x.shape[0])).astype(int))
    x, noise = x[pick], np.asarray(noise, float)[pick]
    impacts, slopes, propagation, valid = space.impacts_and_slopes(x, data.n_flights)
    valid = np.array(valid, dtype=bool)  # the kernel may hand back a read-only mask
    mean = data.at_onsets(impacts)
    columns = [np.ones_like(mean)]
    spread = x.std(axis=0)
    for j, name in enumerate(space.names):
        if name in NOT_DIRECTIONS or not spread[j] > 0.0:
            continue
        step = STEP * spread[j]
        moved = x.copy()
        moved[:, j] += step
        shifted, still = space.impacts(moved, data.n_flights)
        valid &= still
        columns.append((data.at_onsets(shifted) - mean) / step)
    jitter = np.broadcast_to(np.asarray(space.value(x, "jitter"), float), (x.shape[0],))
    weights = 1.0 / (jitter[:, None] ** 2 + data.sigmas**2)
    with np.errstate(all="ignore"):
        directions = np.stack(columns, axis=2)
        sensitivity = impact_sensitivity(data, slopes, propagation)
    valid &= (np.isfinite(directions).all(axis=(1, 2)) & np.isfinite(sensitivity).all(axis=(1, 2))
              & np.isfinite(noise).all(axis=1) & np.isfinite(weights).all(axis=1))
    if not valid.any():
        return None
    observed, replicated = scatter_walk(np.stack([data.times - mean[valid], noise[valid]]),
                                        weights[valid], directions[valid], sensitivity[valid])
    ok = np.isfinite(observed) & np.isfinite(replicated)
    if not ok.any():
        return None
    return AdequacyCheck(observed=float(np.mean(observed[ok])),
                         replicated=float(np.mean(replicated[ok])),
                         p_value=float(np.mean(replicated[ok] >= observed[ok])))


def check_residuals(observed: NDArray, replicated: NDArray, level: float = LEVEL,
                    scatter: AdequacyCheck | None = None) -> Adequacy:
    """The checks on standardised residuals, ``(draws, n)`` each: the observed onsets' and
    onsets replicated from the model at the same draws; ``scatter``, the scatter check
    (:func:`scatter_check`), joins them when given.

    Returns
    -------
    Adequacy
        Each check's statistic (posterior mean, observed and replicated), its p-value, and
        whether every check passes at ``level``.
    """
    observed = np.asarray(observed, float)
    replicated = np.asarray(replicated, float)
    if observed.shape[-1] < MIN_ONSETS:
        return Adequacy(checks={}, adequate=None, level=level)
    lag_obs, lag_rep = lag1_autocorrelation(observed), lag1_autocorrelation(replicated)
    runs_obs, runs_rep = sign_runs(observed), sign_runs(replicated)
    checks = {
        "lag1_autocorrelation": AdequacyCheck(
            observed=float(np.nanmean(lag_obs)), replicated=float(np.nanmean(lag_rep)),
            p_value=float(np.mean(lag_rep >= lag_obs))),
        "sign_runs": AdequacyCheck(
            observed=float(np.mean(runs_obs)), replicated=float(np.mean(runs_rep)),
            p_value=float(np.mean(runs_rep <= runs_obs))),
    }
    if scatter is not None:
        checks["scatter_walk"] = scatter
    return Adequacy(checks=checks, adequate=all(c.p_value >= level for c in checks.values()),
                    level=level)


def adequacy(idata, level: float = LEVEL, log_posterior: LogPosterior | None = None,
             parameters: NDArray | None = None) -> Adequacy:
    """The checks of one model's fit from its InferenceData: the observed onsets, the model's
    noise-free onset times and the replicated ones (``posterior_predictive``), each standardised
    by √(jitter² + σ_i²) of its draw (the noise model's scale). With the fit's
    ``log_posterior`` and its ``parameters`` ``(draws, ndim)``, in the order of the
    InferenceData's draws (chain by chain), the scatter check too."""

    times, sigmas = observed_onsets(idata)
    predictive = idata.posterior_predictive
    model = np.asarray(predictive["onset_time_model"].values, float)
    model = model.reshape(-1, model.shape[-1])
    replicated = np.asarray(predictive["onset_time"].values, float).reshape(model.shape)
    jitter = 1e-3 * np.asarray(idata.posterior["jitter_ms"].values, float).reshape(-1, 1)
    scale = np.sqrt(jitter**2 + sigmas**2)
    scatter = None
    if log_posterior is not None and parameters is not None and times.size >= MIN_ONSETS:
        scatter = scatter_check(log_posterior, np.reshape(parameters, (model.shape[0], -1)),
                                replicated - model)
    return check_residuals((times - model) / scale, (replicated - model) / scale, level,
                           scatter)
