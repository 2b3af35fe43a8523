"""Posterior predictive check: onset-time residuals against bounce number, one panel per model.

Each panel shows observed onset time minus the posterior median prediction (milliseconds)
with the 90 % posterior predictive band (replicated onsets, jitter included) around the same
median, and a darker band for the model's own (noise-free) uncertainty. A model that
describes the bounces leaves residuals scattered evenly inside the band; a model that
does not leaves a structured pattern (a wave, a trend; a lag-1 correlation near 1) and needs
a large jitter to cover it: then the model, not the microphone, is the limit. Each title quotes
the model's adequacy check (:mod:`drumroll.inference.adequacy`). The figure draws the
summary's residuals and bands (:func:`drumroll.inference.summary.onset_residuals`). The panels
share the time axis; each has its own (symmetric) residual scale, quoted in its title as the
rms residual and the fitted jitter, so that the scatter of a good fit is not squashed flat.
The x axis is the bounce number k, so a missing bounce shows as a gap between the points.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from drumroll.inference.results import Summary, p_value_text
from drumroll.reporting.plot_style import (
    BAND,
    DATA_COLOR,
    model_color,
    model_name,
    new_figure,
    ordered_models,
    save_figure,
    style,
)


def _every_bounce(bounces: np.ndarray):
    """k from the first to the last bounce, and a map from per-onset values to values at
    every k (NaN where no onset was observed)."""
    k = np.arange(bounces[0], bounces[-1] + 1)

    def at(values: np.ndarray) -> np.ndarray:
        out = np.full(k.size, np.nan)
        out[bounces - bounces[0]] = values
        return out

    return k, at


def fill_band(ax, bounces: np.ndarray, low: np.ndarray, high: np.ndarray, **style) -> None:
    """Shade ``low``–``high`` over the bounces, broken where a bounce is missing; a bounce with
    neither neighbour observed (the last onset after a gap) gets a box ±0.25 wide, which
    ``fill_between`` over one point would not draw."""
    k, at = _every_bounce(bounces)
    ax.fill_between(k, at(low), at(high), lw=0, **style)
    present = set(bounces.tolist())
    for b, lo, hi in zip(bounces.tolist(), low, high, strict=True):
        if b - 1 not in present and b + 1 not in present:
            ax.fill_between([b - 0.25, b + 0.25], lo, hi, lw=0, **style)


def draw_residuals(summary: Summary):
    """Build the residual figure (a :class:`matplotlib.figure.Figure`), one panel per model
    of ``summary``, each from the model's residuals and bands and titled with its adequacy
    check (the residuals' lag-1 correlation against the model's own noise, the p-value)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    models = ordered_models(summary.models, summary.model)
    fig = new_figure((8.2, 0.7 + 2.1 * len(models)), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(models), 1, sharex=True, squeeze=False)[:, 0])
    for i, (ax, model) in enumerate(zip(axes, models, strict=True)):
        fitted = summary.models[model]
        r = {name: np.asarray(getattr(fitted.residuals, name), float) for name in (
            "residual", "sigma", "low", "high", "model_low", "model_high")}
        t = np.asarray(fitted.residuals.bounce, int)
        color = model_color(model, i)
        ms = 1e3
        # Bands and the connecting line break where a bounce is missing (NaN there).
        k, at = _every_bounce(t)
        fill_band(ax, t, r["low"] * ms, r["high"] * ms, color=color, alpha=0.2, zorder=1)
        if r["model_low"].size:
            fill_band(ax, t, r["model_low"] * ms, r["model_high"] * ms, color=color,
                      alpha=0.45, zorder=2)
        ax.axhline(0.0, color="0.35", lw=0.8, zorder=3)
        ax.plot(k, at(r["residual"]) * ms, color="0.45", lw=0.7, zorder=4)
        yerr = r["sigma"] * ms if np.any(r["sigma"] > 0) else None
        ax.errorbar(t, r["residual"] * ms, yerr=yerr, fmt="o", ms=4, color=DATA_COLOR,
                    mfc="white", mew=1.1, elinewidth=1.0, capsize=0, zorder=5)
        rms = float(np.sqrt(np.mean(r["residual"] ** 2)))
        text = f"rms residual {rms * ms:.2g} ms"
        jitter = fitted.parameters.get("jitter_ms")
        if jitter is not None and jitter.median is not None:
            text += f", jitter σ = {jitter.median:.2g} ms"
        outside = int(np.sum((r["residual"] < r["low"]) | (r["residual"] > r["high"])))
        text += f", {outside}/{t.size} outside the band"
        checked = fitted.adequacy
        lag = checked.checks.get("lag1_autocorrelation") if checked is not None else None
        if lag is not None and lag.observed is not None and lag.p_value is not None:
            text += (f"\nresiduals' lag-1 correlation {lag.observed:.2f} (the noise's "
                     f"{lag.replicated:.2f}, {p_value_text(lag.p_value)})"
                     # its own last line: the right title's last line shares the left
                     # title's baseline, and the whole of this one ran into the model's name
                     + ("" if checked.adequate is not False else "\nthe model misses a pattern"))
        top = 1.08 * ms * float(np.nanmax(np.abs(np.concatenate(
            (r["residual"] + r["sigma"], r["residual"] - r["sigma"], r["low"], r["high"])))))
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
                         label=f"{BAND:.0%} posterior predictive (model + its noise)"))
    if summary.models[models[0]].residuals.model_low:
        handles.append(Patch(facecolor="0.5", alpha=0.55, lw=0,
                             label=f"{BAND:.0%} model only (noise-free)"))
    fig.legend(handles=handles, loc="outside upper center", ncols=len(handles),
               fontsize=9)
    return fig


def plot_residuals(summary: Summary, path: str | os.PathLike[str], *,
                   overwrite: bool = False) -> Path:
    """Write ``residuals.png`` (see :func:`draw_residuals`) to ``path`` atomically."""
    with style():
        fig = draw_residuals(summary)
    return save_figure(fig, path, overwrite=overwrite)
