"""From an emcee chain to ArviZ InferenceData's groups (:class:`~drumroll.inference.draws.Draws`,
convertible to InferenceData), in the units of the paper's tables.

Groups: ``posterior`` (sampled parameters and derived quantities, under the summary names:
``alpha``, ``t_b``, ``t_c``, ``pivot_mm``, ``height_mm``, ``release_speed_m_s``,
``release_angle_deg``, ``jitter_ms``, ``t0_s``, …), ``prior``, ``log_likelihood``
(``onset_time``, per onset, for PSIS-LOO: with Gaussian noise the conditional
log p(t_i | t_{-i}, θ) of :mod:`drumroll.inference.loo`), ``posterior_predictive`` (replicated
``onset_time``, and the noise-free ``onset_time_model`` and ``flight_time_model``),
``observed_data``, ``constant_data`` (the extractor's ``onset_sigma_s``) and ``sample_stats``
(``lp``). Walkers are ArviZ's chains.

Coordinates: ``onset`` holds each observed onset's bounce number k (0, 1, 2, … when none is
missing; a gap where an impact was not heard), ``flight`` the model's flights 1 … K up to the
last observed bounce, gaps included.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from drumroll._version import __version__
from drumroll.inference.draws import Draws
from drumroll.inference.loo import conditional_pointwise
from drumroll.inference.posterior import LogPosterior, scatter_pointwise_and_noise
from drumroll.inference.sampling import Chain
from drumroll.physics.geometry import effective_height
from drumroll.quantities import BY_NAME, DERIVED, DRAW_DERIVED

if TYPE_CHECKING:  # ArviZ takes a second to import: only converting to InferenceData needs it
    from collections.abc import Callable
    from concurrent.futures import Executor

    import arviz as az


def _flat(array: NDArray) -> NDArray:
    """(chain, draw, …) → (chain × draw, …)."""
    return array.reshape((-1, *array.shape[2:]))


def parameter_draws(log_posterior: LogPosterior, samples: NDArray, rng: np.random.Generator
                    ) -> tuple[dict[str, NDArray], NDArray, NDArray]:
    """Sampled parameters, derived quantities and T0 for ``samples`` (…, ndim).

    Returns
    -------
    variables, impacts, t0
        ``variables`` maps summary names to arrays of shape ``samples.shape[:-1]``;
        ``impacts`` (…, K + 1) are the model's impact times τ_0 … τ_K after the first, at
        every bounce up to the last observed one; ``t0`` is T0.
    """
    shape = samples.shape[:-1]
    flat = samples.reshape(-1, samples.shape[-1])
    space = log_posterior.space
    values = space.values(flat)
    bounces = space.bounces_from_values(values, log_posterior.data.n_flights)
    t0 = log_posterior.conditional_t0(flat, rng)
    variables: dict[str, NDArray] = {}
    for name in space.names:
        variables[BY_NAME[name].key] = BY_NAME[name].to_user(values[name])
    for key, quantity in DERIVED.items():
        if quantity.name in space.names:
            continue  # sampled (the power law's t_B)
        value = getattr(bounces, quantity.bounces)
        if not np.all(np.isnan(value)):
            variables[key] = quantity.to_user(value)
    if space.forward.needs_stick:  # eq. 8's effective height and the tip's mass ratio
        h_eff, ratio = effective_height(space.config.stick.shape, values["stick_length"],
                                        values["stick_tip"], values["stick_radius"],
                                        values["pivot"], values["height"])
        for key, value in (("effective_height_mm", h_eff), ("tip_mass_ratio", ratio)):
            variables[key] = DRAW_DERIVED[key].to_user(np.broadcast_to(value, t0.shape))
    if log_posterior.noise == "student-t":  # the scale σ is not the noise's sd
        nu = np.asarray(values["nu"], float)
        with np.errstate(divide="ignore", invalid="ignore"):
            sd = values["jitter"] * np.sqrt(np.where(nu > 2, nu / (nu - 2), np.inf))
        variables["jitter_sd_ms"] = DRAW_DERIVED["jitter_sd_ms"].to_user(
            np.broadcast_to(sd, t0.shape))
    variables["t0_s"] = t0
    variables = {k: np.asarray(v).reshape(shape) for k, v in variables.items()}
    impacts = space.with_contact(bounces.impacts, values.get("contact"), bounces.speed_ratios)
    return variables, impacts.reshape((*shape, -1)), t0.reshape(shape)


def build_draws(log_posterior: LogPosterior, chain: Chain, rng: np.random.Generator,
                n_prior: int = 2000, executor: Executor | None = None,
                idle: Callable[[], int] | None = None) -> Draws:
    """Every group of one model's fit (see the module docstring), as :class:`Draws`; with an
    ``executor``, LOO's terms under Student-t noise with a scattering restitution are shared
    with its processes as they fall idle (``idle()`` of them:
    :func:`~drumroll.inference.posterior.scatter_pointwise_and_noise`, the same numbers)."""
    data = log_posterior.data
    samples = chain.samples
    variables, impacts, t0 = parameter_draws(log_posterior, samples, rng)
    flat_samples = _flat(samples)
    values = log_posterior.space.values(flat_samples)
    scale = np.sqrt(np.asarray(values["jitter"])[:, None] ** 2 + data.sigmas**2)
    if log_posterior.scatters:  # correlated onsets: conditional terms and noise from Σ
        pointwise, noise = scatter_pointwise_and_noise(log_posterior, flat_samples,
                                                       _flat(impacts), rng, executor=executor,
                                                       idle=idle)
    elif log_posterior.noise == "gaussian":  # T0 marginalised: conditional terms (see .loo)
        pointwise = conditional_pointwise(data, _flat(impacts),
                                          np.broadcast_to(values["jitter"], t0.size))
        noise = scale * rng.standard_normal(scale.shape)
    else:  # Student-t: T0 sampled
        pointwise = log_posterior.pointwise(flat_samples, _flat(t0[..., None])[:, 0])
        # Gaussian draws made and dropped, as always, so that every later draw (the
        # replicated onsets, the prior sample) is the one earlier versions stored.
        rng.standard_normal(scale.shape)
        nu = np.broadcast_to(np.asarray(values["nu"], float), scale.shape[:1])[:, None]
        noise = scale * rng.standard_t(nu, size=scale.shape)
    pointwise = pointwise.reshape((*samples.shape[:2], -1))
    model_times = _flat(t0[..., None]) + data.at_onsets(_flat(impacts))
    predicted = (model_times + noise).reshape(pointwise.shape)
    flights = np.diff(impacts, axis=-1)

    prior_samples = log_posterior.space.sample_prior(rng, n_prior)
    prior_variables, _, _ = parameter_draws(log_posterior, prior_samples[None], rng)
    coords = {"onset": data.bounces, "flight": np.arange(1, data.n_flights + 1)}
    dims = {"onset_time": ["onset"], "onset_time_model": ["onset"],
            "flight_time_model": ["flight"], "onset_sigma_s": ["onset"]}
    # The groups, names and dimensions of arviz.from_dict, in its order.
    draws = Draws.from_dict({
        "posterior": variables,
        "posterior_predictive": {"onset_time": predicted,
                                 "onset_time_model": model_times.reshape(pointwise.shape),
                                 "flight_time_model": flights},
        "log_likelihood": {"onset_time": pointwise},
        "sample_stats": {"lp": chain.log_prob},
        "prior": prior_variables,
        "observed_data": {"onset_time": data.times},
        "constant_data": {"onset_sigma_s": data.sigmas},
    }, coords=coords, dims=dims, attrs={"model": log_posterior.space.model,
                                        "noise": log_posterior.noise,
                                        "drumroll_version": __version__})
    draws.sample_stats.attrs.update({
        "tau_steps": [float(t) for t in chain.tau], "tau_parameters": list(
            BY_NAME[n].key for n in log_posterior.space.names),
        "acceptance": chain.acceptance, "n_steps": chain.n_steps, "burn": chain.burn,
        "thin": chain.thin, "converged": int(chain.converged)})
    return draws


def build_inference_data(log_posterior: LogPosterior, chain: Chain, rng: np.random.Generator,
                         n_prior: int = 2000) -> az.InferenceData:
    """:func:`build_draws` as an :class:`arviz.InferenceData`."""
    return build_draws(log_posterior, chain, rng, n_prior).to_inference_data()


def observed_onsets(idata) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Observed onset times (s) and the extractor's per-onset sigmas (s, zeros if absent)."""
    times = np.asarray(idata.observed_data["onset_time"].values, dtype=float)
    sigmas = np.zeros_like(times)
    if "constant_data" in idata.groups() and "onset_sigma_s" in idata.constant_data:
        sigmas = np.nan_to_num(np.asarray(idata.constant_data["onset_sigma_s"].values, float))
    return times, np.broadcast_to(sigmas, times.shape).astype(float)


def observed_bounces(idata) -> NDArray[np.int64]:
    """The bounce number k of each observed onset: the ``onset`` coordinate (0, 1, 2, … in
    files written before bounce numbers were stored, and whenever no bounce is missing)."""
    observed = idata.observed_data["onset_time"]
    if "onset" in observed.coords:
        return np.asarray(observed["onset"].values).astype(np.int64)
    return np.arange(observed.shape[-1], dtype=np.int64)


def jitter_s(idata) -> float:
    """Posterior median of the onset jitter, in seconds (0 if the model has none)."""
    if "jitter_ms" not in idata.posterior:
        return 0.0
    return float(np.nanmedian(idata.posterior["jitter_ms"].values)) * 1e-3
