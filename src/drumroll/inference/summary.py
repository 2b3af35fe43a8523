"""Posterior summaries and sampler diagnostics, in plain numbers and plain words."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from drumroll.inference.comparison import LooResult
from drumroll.inference.convergence import diagnose
from drumroll.inference.inference_data import jitter_s, observed_bounces, observed_onsets
from drumroll.inference.results import (
    Diagnostics,
    FlightSeries,
    ObservedFlights,
    OnsetResiduals,
    ParameterSummary,
    json_number,
)
from drumroll.inference.sampling import Chain
from drumroll.onsets.table import single_flights
from drumroll.quantities import QUANTITIES
from drumroll.stats import central_band, hdi

if TYPE_CHECKING:
    import arviz as az

    from drumroll.inference.draws import Draws

    #: One fit's groups: drumroll's own (the estimate's) or ArviZ's (any caller's).
    Fit = Draws | az.InferenceData


def parameter_summary(idata: Fit, hdi_prob: float = 0.9
                      ) -> dict[str, ParameterSummary]:
    """Mean, sd, median, HDI, R-hat and bulk/tail ESS of every posterior variable, by name
    (ESS treats the walkers as chains, R-hat groups of walkers:
    :mod:`~drumroll.inference.convergence`, the same numbers the sampler's stopping rule
    checked)."""
    posterior = idata.posterior
    stats = diagnose({name: np.asarray(values) for name, values in posterior.data_vars.items()})
    out = {}
    for name, values in posterior.data_vars.items():
        draws = np.asarray(values)
        low, high = hdi(draws, hdi_prob)
        zero = (json_number(np.mean(draws == 0.0)) if _prior_atom(idata, str(name)) == 0.0
                else None)
        out[str(name)] = ParameterSummary(
            mean=json_number(draws.mean()), sd=json_number(draws.std(ddof=1)),
            median=json_number(np.median(draws)),
            hdi_low=json_number(low), hdi_high=json_number(high), hdi_prob=hdi_prob,
            r_hat=json_number(stats[name]["r_hat"]), ess_bulk=json_number(stats[name]["ess_bulk"]),
            ess_tail=json_number(stats[name]["ess_tail"]), probability_zero=zero)
    return out


#: The share of prior draws at one value from which that value is an atom of the prior.
_ATOM_SHARE = 0.01


def _prior_atom(idata: Fit, name: str) -> float | None:
    """The lower end of ``name``'s prior draws where the prior holds it with a probability of
    its own (an atom: :class:`~drumroll.distributions.OrZero`'s 0), else None."""
    if "prior" not in idata.groups() or name not in idata.prior:
        return None
    prior = np.asarray(idata.prior[name]).ravel()
    if not prior.size:
        return None
    lowest = float(np.min(prior))
    return lowest if np.mean(prior == lowest) > _ATOM_SHARE else None


def _at_prior_edge(idata: Fit, name: str) -> str | None:
    """'lower'/'upper' when the posterior is cut off by that end of the prior's support.

    The posterior is cut off when the prior's bound lies within two posterior standard
    deviations of the posterior median: the bound, not the data, then shapes that side of
    the interval (a scale-free test: it works for log-uniform jitter priors too). A lower end
    that the prior holds with a probability of its own (an atom: "no contact") is an answer,
    not a cut: the summary gives its posterior probability instead.
    """
    if "prior" not in idata.groups() or name not in idata.prior:
        return None
    prior = np.asarray(idata.prior[name]).ravel()
    post = np.asarray(idata.posterior[name]).ravel()
    median, sd = np.median(post), np.std(post)
    if not sd > 0:
        return None
    if median - np.min(prior) < 2.0 * sd and _prior_atom(idata, name) is None:
        return "lower"
    if np.max(prior) - median < 2.0 * sd:
        return "upper"
    return None


def diagnostics(idata: Fit, chain: Chain, loo: LooResult | None,
                settings: Any) -> Diagnostics:
    """Convergence figures of one fit and warnings that say what to do.

    Warnings are raised for: a chain stopped at ``max_steps`` before every reported quantity
    met the targets; R-hat above the target; bulk or tail ESS below it; an acceptance fraction
    outside 0.1–0.7; onsets with Pareto k > 0.7 (PSIS-LOO unreliable there); a sampled
    parameter piled up against an end of its prior (the prior, not the data, decides it).
    """
    sampler = settings.sampler
    model = idata.attrs.get("model", "?")
    sampled = list(idata.sample_stats.attrs.get("tau_parameters", []))
    stats = diagnose({name: np.asarray(idata.posterior[name]) for name in sampled})
    warnings: list[str] = []
    if not chain.converged:
        warnings.append(f"{model}: the run stopped at the step limit ({chain.n_steps} steps) "
                        f"before every reported quantity had ESS ≥ {sampler.target_ess:.0f} "
                        f"and R-hat < {sampler.max_r_hat} (in a chain of at least "
                        f"{sampler.tau_multiple:g} autocorrelation times); raise [sampler] "
                        "max_steps")
    for name in sampled:
        rh, eb, et = (stats[name][key] for key in ("r_hat", "ess_bulk", "ess_tail"))
        if not rh < sampler.max_r_hat:
            warnings.append(f"{model}: R-hat of {name} is {rh:.4f} (target < "
                            f"{sampler.max_r_hat}): the walkers disagree; run longer")
        if not min(eb, et) >= sampler.target_ess:
            warnings.append(f"{model}: {name} has only {min(eb, et):.0f} effective samples "
                            f"(target {sampler.target_ess:.0f}); run longer")
        edge = _at_prior_edge(idata, name)
        if edge:
            quantity = QUANTITIES.get(name)
            consequence = (f"; {quantity.at_lower_end}" if edge == "lower" and quantity
                           and quantity.at_lower_end else "")
            warnings.append(f"{model}: {name} piles up at the {edge} end of its prior: the "
                            f"prior, not the data, sets that side of its interval{consequence}")
    if not 0.1 <= chain.acceptance <= 0.7:
        warnings.append(f"{model}: acceptance fraction {chain.acceptance:.2f} is outside "
                        "0.1–0.7; the sampler is struggling")
    if loo is not None and loo.bad_onsets:
        listed = ", ".join(str(i) for i in loo.bad_onsets)
        # Named by bounce number, as every other message names them (a roll with gaps or
        # numbered from a missed impact has onset i at another bounce).
        one = len(loo.bad_onsets) == 1
        which, it, they, fit = (("the onset of bounce", "it", "it is", "fits") if one else
                                ("the onsets of bounces", "them", "they are", "fit"))
        warnings.append(f"{model}: PSIS-LOO is approximate for {which} {listed} (Pareto k > "
                        f"0.7): leaving {it} out moves the posterior a lot, because {they} "
                        f"influential (the first onset anchors every flight) or {fit} badly; "
                        f"check {it} in residuals.png, and treat a small Δelpd with care")
    finite_tau = chain.tau[np.isfinite(chain.tau)]
    return Diagnostics(
        converged=bool(chain.converged), n_steps=int(chain.n_steps), burn=int(chain.burn),
        thin=int(chain.thin), walkers=int(chain.samples.shape[0]),
        draws=int(chain.samples.shape[0] * chain.samples.shape[1]),
        tau_max=json_number(finite_tau.max()) if finite_tau.size else None,
        acceptance=json_number(chain.acceptance),
        r_hat_max=json_number(max((stats[n]["r_hat"] for n in sampled), default=math.nan)),
        ess_bulk_min=json_number(min((stats[n]["ess_bulk"] for n in sampled),
                                     default=math.nan)),
        ess_tail_min=json_number(min((stats[n]["ess_tail"] for n in sampled),
                                     default=math.nan)),
        checks=int(chain.checks), target_ess=float(sampler.target_ess),
        max_r_hat=float(sampler.max_r_hat), warnings=tuple(warnings))


def flight_series(idata: Fit, prob: float = 0.9) -> FlightSeries:
    """The posterior median and central ``prob`` band of a model's noise-free flight times
    (``posterior_predictive.flight_time_model``)."""
    draws = np.asarray(idata.posterior_predictive["flight_time_model"].values, float)
    low, median, high = central_band(draws.reshape(-1, draws.shape[-1]), prob)
    return FlightSeries(median=tuple(map(float, median)), low=tuple(map(float, low)),
                        high=tuple(map(float, high)), prob=prob)


def onset_residuals(idata: Fit, prob: float = 0.9) -> OnsetResiduals:
    """A model's onset residuals and bands (see
    :class:`~drumroll.inference.results.OnsetResiduals`): the posterior predictive check of
    ``residuals.png``."""
    times, sigmas = observed_onsets(idata)
    predictive = idata.posterior_predictive
    replicated = np.asarray(predictive["onset_time"].values, float)
    low, median, high = central_band(replicated.reshape(-1, replicated.shape[-1]), prob)
    model_low = model_high = ()
    if "onset_time_model" in predictive:
        model = np.asarray(predictive["onset_time_model"].values, float)
        m_low, _, m_high = central_band(model.reshape(-1, model.shape[-1]), prob)
        model_low, model_high = _floats(m_low - median), _floats(m_high - median)
    return OnsetResiduals(
        bounce=tuple(int(k) for k in observed_bounces(idata)),
        residual=_floats(times - median), sigma=_floats(sigmas), low=_floats(low - median),
        high=_floats(high - median), model_low=model_low, model_high=model_high, prob=prob)


def _floats(values: NDArray) -> tuple[float, ...]:
    return tuple(float(v) for v in values)


def observed_flights(idata: Fit) -> ObservedFlights:
    """The observed flight times and their 1σ errors (see
    :class:`~drumroll.inference.results.ObservedFlights`), with the posterior median jitter
    of ``idata``'s model."""
    times, sigmas = observed_onsets(idata)
    bounces = observed_bounces(idata)
    var = jitter_s(idata) ** 2 + sigmas**2
    ends = single_flights(bounces)
    flights = np.full(int(bounces[-1]) if bounces.size else 0, np.nan)
    errors = flights.copy()
    flights[bounces[ends] - 1] = times[ends] - times[ends - 1]
    errors[bounces[ends] - 1] = np.sqrt(var[ends - 1] + var[ends])
    return ObservedFlights(time_s=tuple(json_number(v) for v in flights),
                           err_s=tuple(json_number(v) for v in errors))
