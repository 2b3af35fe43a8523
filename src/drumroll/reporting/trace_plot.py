"""The sampler trace: has the ensemble forgotten where it started, and is it mixing?

One row per sampled parameter: on the left every walker's path after burn-in (all walkers
faint, four highlighted so that single paths can be followed), on the right the marginal
histogram of all draws with the 90 % interval shaded. Each row's title gives the R-hat and
the bulk effective sample size it is given (those of ``summary.json``, computed on every
draw). Slow drifts, walkers stuck apart or a marginal with several
humps are what to look for.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from drumroll.inference.results import ParameterSummary
from drumroll.reporting.plot_style import (
    BAND,
    OKABE_ITO,
    model_color,
    model_name,
    new_figure,
    parameter_label,
    parameter_symbol,
    sampled_parameters,
    save_figure,
    style,
)
from drumroll.stats import central_band

#: Colours of the highlighted walkers (none of them a model colour).
_HIGHLIGHT = (OKABE_ITO["orange"], OKABE_ITO["purple"], OKABE_ITO["sky"])
#: The figure's width, each row's height (its title and the gap above it included), and
#: the margins, in inches: the suptitle's two lines and the marginal's two-line title on top,
#: the step axis below, the tick labels and parameter label on the left.
WIDTH_IN, ROW_IN, GAP_IN = 8.6, 1.38, 0.36
TOP_IN, BOTTOM_IN, LEFT_IN, RIGHT_IN = 0.95, 0.5, 0.9, 0.1
#: The suptitle's top below the figure's, in inches.
SUPTITLE_IN = 0.08


def _attr(idata, name: str) -> float | None:
    """A number from ``sample_stats.attrs`` (None when absent)."""
    if "sample_stats" not in idata.groups():
        return None
    value = idata.sample_stats.attrs.get(name)
    if value is None:
        return None
    try:
        return float(np.max(np.asarray(value, dtype=float)))
    except (TypeError, ValueError):
        return None


def draw_trace(idata, stats: Mapping[str, ParameterSummary], max_r_hat: float = 1.01,
               n_highlight: int = 3):
    """Build the trace figure (a :class:`matplotlib.figure.Figure`) of ``idata``.

    Parameters
    ----------
    idata
        One model's InferenceData (walkers as chains; its stored draws may be thinned).
    stats
        The summaries of its variables computed on every draw: the R-hat and bulk ESS in
        the titles are these, the ones ``summary.json`` gives.
    max_r_hat
        The sampler's R-hat target (``[sampler] max_r_hat``): an R-hat above it is flagged.
    n_highlight
        Number of walkers drawn in colour over the faint rest.
    """
    from matplotlib.collections import LineCollection

    names = sampled_parameters(idata)
    if not names:
        raise ValueError("the posterior has no varying parameter to draw")
    model = str(idata.attrs.get("model", ""))
    color = model_color(model)

    n_chain, n_draw = idata.posterior[names[0]].shape
    burn, thin = _attr(idata, "burn"), _attr(idata, "thin")
    if burn is not None and thin:
        steps = burn + thin * np.arange(n_draw)
        xlabel = "sampler step (after burn-in)"
    else:
        steps = np.arange(n_draw)
        xlabel = "draw"
    highlight = np.unique(np.linspace(0, n_chain - 1, min(n_highlight, n_chain)).astype(int))

    height = TOP_IN + BOTTOM_IN + ROW_IN * len(names)
    fig = new_figure((WIDTH_IN, height))
    # Margins fixed in inches rather than a layout engine's: the rows are alike (a title,
    # tick labels of a few digits, a label), and constrained layout measured every one of
    # their texts, 40 % of the figure's time.
    axes = np.atleast_2d(fig.subplots(
        len(names), 2, sharex="col", squeeze=False, gridspec_kw=dict(
            width_ratios=[4.2, 1], left=LEFT_IN / WIDTH_IN, right=1.0 - RIGHT_IN / WIDTH_IN,
            top=1.0 - TOP_IN / height, bottom=BOTTOM_IN / height, wspace=0.04,
            hspace=GAP_IN / (ROW_IN - GAP_IN))))
    for row, name in enumerate(names):
        ax, ax_hist = axes[row]
        values = np.asarray(idata.posterior[name].values, float)
        # Every walker as one collection: one artist instead of one line per walker (with
        # a hundred walkers, most of the figure's time went to building Line2D objects).
        paths = np.stack([np.broadcast_to(steps, values.shape), values], axis=-1)
        ax.add_collection(LineCollection(paths, colors="0.55", linewidths=0.4, alpha=0.35,
                                         zorder=1))
        ax.autoscale_view()
        for j, chain in enumerate(highlight):
            ax.plot(steps, values[chain], color=_HIGHLIGHT[j % len(_HIGHLIGHT)], lw=0.9,
                    zorder=2)
        ax.set_ylabel(parameter_label(name))
        ax.margins(x=0)
        flat = values.ravel()
        flat = flat[np.isfinite(flat)]
        lo, mid, hi = central_band(flat)
        ax_hist.hist(flat, bins=40, orientation="horizontal", histtype="stepfilled",
                     color=color, alpha=0.35, lw=0)
        ax_hist.hist(flat, bins=40, orientation="horizontal", histtype="step", color=color,
                     lw=1.0)
        ax_hist.axhspan(lo, hi, color=color, alpha=0.12, lw=0, zorder=0)
        ax_hist.axhline(mid, color=color, lw=1.2)
        ax_hist.set_ylim(ax.get_ylim())
        ax_hist.tick_params(labelleft=False, left=False)
        ax_hist.set_xticks([])
        ax_hist.spines["bottom"].set_visible(False)
        rhat, ess = (math.nan if value is None else float(value)
                     for value in (stats[name].r_hat, stats[name].ess_bulk))
        flag = np.isfinite(rhat) and rhat >= max_r_hat
        ax.set_title(f"{parameter_symbol(name)}:  $\\hat{{R}}$ = {rhat:.4f}"
                     f"{'  (not below ' + str(max_r_hat) + ')' if flag else ''},  "
                     f"bulk ESS = {ess:.0f}", loc="left", fontsize=9.5,
                     color=OKABE_ITO["vermillion"] if flag else "black")
    axes[-1, 0].set_xlabel(xlabel)
    axes[0, 1].set_title(f"marginal\n(median, {BAND:.0%})", fontsize=9)

    details = [f"{n_chain} walkers × {n_draw} draws"]
    if burn is not None:
        details.append(f"burn-in {burn:.0f} steps")
    if thin:
        details.append(f"thinned by {thin:.0f}")
    tau = _attr(idata, "tau_steps")
    if tau is not None:
        details.append(f"max autocorrelation time {tau:.0f} steps")
    fig.suptitle(f"{model_name(model)}: sampler trace, {len(highlight)} walkers in colour\n"
                 f"({', '.join(details)})", fontsize=10, va="top",
                 y=1.0 - SUPTITLE_IN / fig.get_figheight())
    return fig


def plot_trace(idata, stats: Mapping[str, ParameterSummary], path: str | os.PathLike[str], *,
               max_r_hat: float = 1.01, overwrite: bool = False) -> Path:
    """Write ``trace.png`` (see :func:`draw_trace`) to ``path`` atomically."""
    with style():
        fig = draw_trace(idata, stats, max_r_hat)
    return save_figure(fig, path, overwrite=overwrite)
