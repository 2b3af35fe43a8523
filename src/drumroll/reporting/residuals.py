"""Posterior predictive check: onset-time residuals against bounce number, one panel per model.

Each panel shows observed onset time minus the posterior median prediction (milliseconds)
with the 90 % posterior predictive band (replicated onsets, jitter included) around the same
median, and a darker band for the model's own (noise-free) uncertainty. A model that
describes the bounces leaves residuals scattered evenly inside the band; a model that
does not leaves a structured pattern (a wave, a trend; a lag-1 correlation near 1) and needs
a large jitter to cover it: then the model, not the microphone, is the limit. The panels
share the time axis; each has its own (symmetric) residual scale, quoted in its title as the
rms residual and the fitted jitter, so that the scatter of a good fit is not squashed flat.
The x axis is the bounce number k, so a missing bounce shows as a gap between the points.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from drumroll.inference.inference_data import observed_bounces, observed_onsets
from drumroll.reporting.plot_style import (
    BAND,
    DATA_COLOR,
    flat_draws,
    model_color,
    model_name,
    new_figure,
    ordered_models,
    save_figure,
    style,
)
from drumroll.stats import central_band


def noise_free_onsets(idata) -> np.ndarray | None:
    """Draws of the model's noise-free impact times t0 + Σ_{j ≤ k} T_j at every bounce
    k = 0 … K, (draws, K + 1); None if absent."""
    if "t0_s" not in idata.posterior or "flight_time_model" not in idata.posterior_predictive:
        return None
    t0 = flat_draws(idata, "posterior", "t0_s")
    flights = flat_draws(idata, "posterior_predictive", "flight_time_model")
    zeros = np.zeros((flights.shape[0], 1))
    return t0[:, None] + np.concatenate((zeros, np.cumsum(flights, axis=1)), axis=1)


def onset_residuals(idata) -> dict[str, np.ndarray]:
    """Residuals and bands of one model, in seconds, relative to the median prediction.

    Returns
    -------
    dict
        ``time`` (observed onsets), ``bounce`` (their bounce numbers), ``residual``
        (observed − median replicated onset),
        ``sigma`` (extractor sigmas), ``pp_lo``/``pp_hi`` (90 % posterior predictive band),
        and, when the noise-free prediction can be built, ``model_lo``/``model_hi``.
    """
    times, sigmas = observed_onsets(idata)
    replicated = flat_draws(idata, "posterior_predictive", "onset_time")
    lo, mid, hi = central_band(replicated)
    bounces = observed_bounces(idata)
    out = {"time": times, "bounce": bounces, "residual": times - mid, "sigma": sigmas,
           "pp_lo": lo - mid, "pp_hi": hi - mid}
    model = noise_free_onsets(idata)
    if model is not None and model.shape[1] > bounces[-1]:
        m_lo, _, m_hi = central_band(model[:, bounces])
        out["model_lo"], out["model_hi"] = m_lo - mid, m_hi - mid
    return out


def lag_one_correlation(residual: np.ndarray) -> float:
    """Correlation of successive residuals: near 0 (within ±2/√n) for noise, near 1 for a
    smooth pattern the model misses. NaN for fewer than four onsets."""
    r = np.asarray(residual, float)
    r = r[np.isfinite(r)]
    if r.size < 4:
        return float("nan")
    r = r - r.mean()
    denominator = float(np.sum(r * r))
    return float(np.sum(r[1:] * r[:-1]) / denominator) if denominator > 0 else float("nan")


def _every_bounce(bounces: np.ndarray):
    """k from the first to the last bounce, and a map from per-onset values to values at
    every k (NaN where no onset was observed)."""
    k = np.arange(bounces[0], bounces[-1] + 1)

    def at(values: np.ndarray) -> np.ndarray:
        out = np.full(k.size, np.nan)
        out[bounces - bounces[0]] = values
        return out

    return k, at


def draw_residuals(idatas: dict, main_model: str | None = None):
    """Build the residual figure (a :class:`matplotlib.figure.Figure`), one panel per model."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    models = ordered_models(idatas, main_model)
    fig = new_figure((8.2, 0.7 + 2.1 * len(models)), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(models), 1, sharex=True, squeeze=False)[:, 0])
    for i, (ax, model) in enumerate(zip(axes, models, strict=True)):
        idata = idatas[model]
        r = onset_residuals(idata)
        color = model_color(model, i)
        t = r["bounce"]
        ms = 1e3
        # Bands and the connecting line break where a bounce is missing (NaN there).
        k, at = _every_bounce(t)
        ax.fill_between(k, at(r["pp_lo"]) * ms, at(r["pp_hi"]) * ms, color=color, alpha=0.2,
                        lw=0, zorder=1)
        if "model_lo" in r:
            ax.fill_between(k, at(r["model_lo"]) * ms, at(r["model_hi"]) * ms, color=color,
                            alpha=0.45, lw=0, zorder=2)
        ax.axhline(0.0, color="0.35", lw=0.8, zorder=3)
        ax.plot(k, at(r["residual"]) * ms, color="0.45", lw=0.7, zorder=4)
        yerr = r["sigma"] * ms if np.any(r["sigma"] > 0) else None
        ax.errorbar(t, r["residual"] * ms, yerr=yerr, fmt="o", ms=4, color=DATA_COLOR,
                    mfc="white", mew=1.1, elinewidth=1.0, capsize=0, zorder=5)
        rms = float(np.sqrt(np.mean(r["residual"] ** 2)))
        text = f"rms residual {rms * ms:.2g} ms"
        if "jitter_ms" in idata.posterior:
            text += f", jitter σ = {float(np.median(idata.posterior['jitter_ms'])):.2g} ms"
        outside = int(np.sum((r["residual"] < r["pp_lo"]) | (r["residual"] > r["pp_hi"])))
        text += f", {outside}/{t.size} outside the band"
        lag1 = lag_one_correlation(r["residual"])
        if np.isfinite(lag1):
            text += f", lag-1 correlation {lag1:.2f}"
        top = 1.08 * ms * float(np.nanmax(np.abs(np.concatenate(
            (r["residual"] + r["sigma"], r["residual"] - r["sigma"], r["pp_lo"], r["pp_hi"])))))
        if top > 0:
            ax.set_ylim(-top, top)
        ax.set_title(f"{model_name(model)}", loc="left", color=color, fontweight="bold")
        ax.set_title(text, loc="right", fontsize=9)
        ax.set_ylabel("observed − median\nprediction (ms)")
        ax.grid(True, color="0.92", lw=0.6)
        ax.set_axisbelow(True)
    axes[-1].set_xlabel("bounce number $k$")
    axes[-1].xaxis.set_major_locator(MaxNLocator(integer=True, steps=[1, 2, 5, 10]))
    handles = [Line2D([], [], ls="", marker="o", ms=4, color=DATA_COLOR, mfc="white",
                      mew=1.1, label="detected onsets")]
    handles.append(Patch(facecolor="0.5", alpha=0.25, lw=0,
                         label=f"{BAND:.0%} posterior predictive (model + jitter)"))
    if any("model_lo" in onset_residuals(idatas[m]) for m in models[:1]):
        handles.append(Patch(facecolor="0.5", alpha=0.55, lw=0,
                             label=f"{BAND:.0%} model only (noise-free)"))
    fig.legend(handles=handles, loc="outside upper center", ncols=len(handles),
               fontsize=9)
    return fig


def plot_residuals(idatas: dict, path: str | os.PathLike[str], main_model: str | None = None,
                   *, overwrite: bool = False) -> Path:
    """Write ``residuals.png`` (see :func:`draw_residuals`) to ``path`` atomically."""
    with style():
        fig = draw_residuals(idatas, main_model)
    return save_figure(fig, path, overwrite=overwrite)
