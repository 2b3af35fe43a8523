"""Does a fitted model describe the onsets? Posterior predictive checks of the residuals.

A model can fit a roll with small error bars and still be wrong: a ball whose restitution
falls with impact speed, fitted with a constant α, leaves residuals that are one smooth wave
(the real ping-pong of ``../shared/real``: neighbouring residuals correlate at 0.7), and the
error bars then describe the model, not the bouncer. Timing noise that the model explains
leaves residuals that are independent from one onset to the next. Two statistics of the
standardised residuals r_i = (t_i − μ_i(θ)) / s_i(θ), in time order, see the difference:

* the lag-1 autocorrelation, large when neighbouring residuals share a sign and a size;
* the number of runs of one sign (Wald and Wolfowitz 1940), small when they share a sign.

Each is compared with its distribution under the model by the posterior predictive p-value
(Gelman, Meng and Stern 1996, "Posterior predictive assessment of model fitness via realized
discrepancies"): for every posterior draw θ, the statistic of the observed residuals against
that of residuals replicated from the model's own noise at θ,
p = Pr(T(r_rep; θ) ≥ T(r; θ) | data) (fewer runs, for the runs). A model whose p is below
:data:`LEVEL` in either check is flagged inadequate: with two checks, a model that is right is
flagged in at most 2 % of rolls (posterior predictive p-values are, if anything, conservative:
Meng 1994).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from drumroll.inference.inference_data import observed_onsets
from drumroll.inference.results import Adequacy, AdequacyCheck

#: Posterior predictive p-value below which a check fails.
LEVEL = 0.01
#: Fewest onsets the checks need (three residuals make one lag-1 pair more than a mean).
MIN_ONSETS = 4


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


def check_residuals(observed: NDArray, replicated: NDArray, level: float = LEVEL) -> Adequacy:
    """The two checks on standardised residuals, ``(draws, n)`` each: the observed onsets' and
    onsets replicated from the model at the same draws.

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
    return Adequacy(checks=checks, adequate=all(c.p_value >= level for c in checks.values()),
                    level=level)


def adequacy(idata, level: float = LEVEL) -> Adequacy:
    """The checks of one model's fit from its InferenceData: the observed onsets, the model's
    noise-free onset times and the replicated ones (``posterior_predictive``), each standardised
    by √(jitter² + σ_i²) of its draw (the noise model's scale)."""

    times, sigmas = observed_onsets(idata)
    predictive = idata.posterior_predictive
    model = np.asarray(predictive["onset_time_model"].values, float)
    model = model.reshape(-1, model.shape[-1])
    replicated = np.asarray(predictive["onset_time"].values, float).reshape(model.shape)
    jitter = 1e-3 * np.asarray(idata.posterior["jitter_ms"].values, float).reshape(-1, 1)
    scale = np.sqrt(jitter**2 + sigmas**2)
    return check_residuals((times - model) / scale, (replicated - model) / scale, level)
