"""The bounce series (after the paper's Figure 5): flight time against bounce number.

Top panel: the observed flight times T_k = t_k − t_{k−1} on a log axis, with error bars from
the onset timing (σ_T² = σ_{k−1}² + σ_k², σ_k² = jitter² + extractor σ_k²), and for each
model the posterior median of its noise-free flight times and their 90 % band. A flight is
observed only between the onsets of consecutive bounces k − 1 and k: where a bounce was not
heard, the two flights on either side of it have no data point (the model's curve runs on).
A pure power law is a straight line here; the exact pendulum bends slightly.

Bottom panel: the same, minus the main model's median, in milliseconds. The curvature that
separates the exact pendulum from the small-angle model, invisible on the log plot, shows as
a systematic trend of the data (and of the other models' curves) away from zero.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from drumroll.inference.results import ParameterSummary, Summary
from drumroll.reporting.numbers import format_value_error
from drumroll.reporting.plot_style import (
    DATA_COLOR,
    model_color,
    model_linestyle,
    model_name,
    new_figure,
    ordered_models,
    save_figure,
    style,
)


def _fit_text(parameters: dict[str, ParameterSummary]) -> str:
    """``α = 0.880 ± 0.001, t_B = 0.253 ± 0.001 s`` from a model's summaries, for the legend."""
    parts = []
    for key, symbol, unit in (("alpha", "α", ""), ("t_b", "$t_B$", "s")):
        stats = parameters.get(key)
        if stats is not None and stats.mean is not None and stats.sd is not None:
            text = format_value_error(stats.mean, stats.sd, significant=1, unit=unit)
            parts.append(f"{symbol} = {text}")
    return ", ".join(parts)


def _array(values: tuple[float | None, ...]) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def draw_bounce_series(summary: Summary):
    """Build the bounce-series figure (a :class:`matplotlib.figure.Figure`) of an estimate's
    summary: every model's flights (median and band), the observed flights with their errors,
    the main model's median as the lower panel's reference."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import LogFormatterSciNotation, LogLocator, MaxNLocator, ScalarFormatter

    main_model = summary.model
    models = ordered_models(summary.models, main_model)
    t_obs = _array(summary.observed_flights.time_s)
    t_err = _array(summary.observed_flights.err_s)

    fig = new_figure((7.6, 6.6), layout="constrained")
    ax, ax_res = fig.subplots(2, 1, sharex=True, height_ratios=[2.4, 1.3])

    curves = {m: tuple(np.asarray(getattr(summary.models[m].flights, side), float)
                       for side in ("low", "median", "high")) for m in models}
    prob = summary.models[main_model].flights.prob
    n = min(t_obs.size, *(c[1].size for c in curves.values()))
    k = np.arange(1, n + 1)
    t_obs, t_err = t_obs[:n], t_err[:n]
    reference = curves[main_model][1][:n]

    handles, labels = [], []
    # Bands under lines under data; among models the main one is on top.
    for i, model in reversed(list(enumerate(models))):
        lo, mid, hi = (c[:n] for c in curves[model])
        color = model_color(model, i)
        layer = 0.1 * (len(models) - i)
        for axis, shift in ((ax, 0.0), (ax_res, reference)):
            scale = 1.0 if axis is ax else 1e3
            axis.fill_between(k, (lo - shift) * scale, (hi - shift) * scale, color=color,
                              alpha=0.22, lw=0, zorder=1 + layer)
            axis.plot(k, (mid - shift) * scale, color=color, lw=1.6, zorder=3 + layer,
                      ls=model_linestyle(model))
    for i, model in enumerate(models):
        color = model_color(model, i)
        handles.append((Patch(facecolor=color, alpha=0.22, lw=0),
                        Line2D([], [], color=color, lw=1.6,
                               ls=model_linestyle(model))))
        fit = _fit_text(summary.models[model].parameters)
        labels.append(f"{model_name(model)}" + (f": {fit}" if fit else ""))

    kw = dict(fmt="o", ms=3.8, color=DATA_COLOR, mfc="white", mew=1.1, elinewidth=1.0,
              capsize=0, zorder=10)
    data = ax.errorbar(k, t_obs, yerr=t_err, **kw)
    ax_res.errorbar(k, (t_obs - reference) * 1e3, yerr=t_err * 1e3, **kw)
    handles.insert(0, data)
    labels.insert(0, f"data ({int(np.isfinite(t_obs).sum())} flights, ±1σ)")

    ax.set_yscale("log")
    ax.set_ylabel("flight time $T_k$ (s)")
    ax.set_title(f"Bounce series: model medians and {prob:.0%} posterior bands")
    ax.legend(handles, labels, loc="lower left", handlelength=2.6)
    ax.grid(True, which="major", color="0.9", lw=0.6)
    ax.grid(True, which="minor", axis="y", color="0.95", lw=0.4)
    ax.set_axisbelow(True)
    positive = t_obs[np.isfinite(t_obs) & (t_obs > 0)]
    if positive.size and positive.max() / positive.min() < 30:  # plain numbers read better
        fmt = ScalarFormatter()
        fmt.set_scientific(False)
        ax.yaxis.set_major_formatter(fmt)
        ax.yaxis.set_minor_locator(LogLocator(subs=(2, 5)))
        ax.yaxis.set_minor_formatter(ScalarFormatter())
    else:
        ax.yaxis.set_major_formatter(LogFormatterSciNotation())

    ax_res.axhline(0.0, color="0.4", lw=0.8, zorder=2)
    ax_res.set_ylabel(f"$T_k$ − {model_name(main_model)}\nmedian (ms)")
    ax_res.set_xlabel("bounce number $k$")
    ax_res.grid(True, color="0.92", lw=0.6)
    ax_res.set_axisbelow(True)
    ax_res.set_xlim(0.4, n + 0.6)
    ax_res.xaxis.set_major_locator(MaxNLocator(integer=True, steps=[1, 2, 5, 10]))
    return fig


def plot_bounce_series(summary: Summary, path: str | os.PathLike[str], *,
                       overwrite: bool = False) -> Path:
    """Write ``bounce_series.png`` (see :func:`draw_bounce_series`) to ``path`` atomically."""
    with style():
        fig = draw_bounce_series(summary)
    return save_figure(fig, path, overwrite=overwrite)
