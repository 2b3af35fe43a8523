"""The corner plot of the main model's posterior (corner.py).

Every sampled parameter plus t_B, with units in the labels, the 5, 50 and 95 % quantiles
marked on the marginals, a title ``median +up −down`` rounded to its error, and the true
values overlaid when they are known (simulations). The 2-D panels show the posterior's
correlations: in the small-angle model the pivot, the height and the release speed lie along
a ridge; the exact pendulum narrows it through the curvature of the bounce series.
"""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import numpy as np

from drumroll.reporting.numbers import error_decimals
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

#: Quantiles marked on the marginals.
QUANTILES: tuple[float, float, float] = ((1 - BAND) / 2, 0.5, (1 + BAND) / 2)


def corner_parameters(idata) -> list[str]:
    """The sampled parameters of ``idata``, with ``t_b`` added (it is derived in most models)."""
    names = sampled_parameters(idata)
    if "t_b" in idata.posterior and "t_b" not in names \
            and np.ptp(idata.posterior["t_b"].values) > 0:
        names.append("t_b")
    return names


def quantile_title(key: str, values: np.ndarray) -> str:
    """``α = 0.880^{+0.002}_{−0.003}`` with the 5/50/95 % quantiles, rounded to the error."""
    lo, mid, hi = np.quantile(values, QUANTILES)
    up, down = hi - mid, mid - lo
    positive = [e for e in (up, down) if e > 0]
    reference = min(positive) if positive else (abs(mid) * 1e-3 or 1.0)
    decimals = max(error_decimals(reference), 0)
    unit = parameter_label(key)[len(parameter_symbol(key)):].strip()
    unit = f" {unit[1:-1]}" if unit.startswith("(") else ""
    return (f"{parameter_symbol(key)} = ${mid:.{decimals}f}"
            f"^{{+{up:.{decimals}f}}}_{{-{down:.{decimals}f}}}$" + unit)


def draw_corner(idata, truths: dict[str, float] | None = None):
    """Build the corner figure (a :class:`matplotlib.figure.Figure`) of ``idata``'s posterior.

    Parameters
    ----------
    idata
        One model's InferenceData.
    truths
        Known parameter values by posterior name (e.g. ``{"alpha": 0.88, "pivot_mm": 131}``);
        names that are not plotted are ignored.
    """
    import corner

    names = corner_parameters(idata)
    if not names:
        raise ValueError("the posterior has no varying parameter to draw")
    samples = np.column_stack([np.asarray(idata.posterior[n].values, float).ravel()
                               for n in names])
    samples = samples[np.all(np.isfinite(samples), axis=1)]
    n_draws = samples.shape[0]
    k = len(names)
    size = max(4.5, 1.55 * k + 1.2)
    fig = new_figure((size, size))
    model = str(idata.attrs.get("model", ""))
    color = model_color(model)
    truth_list = None
    ranges = [(float(lo), float(hi)) for lo, hi in zip(samples.min(axis=0), samples.max(axis=0),
                                                        strict=True)]
    off_scale: dict[int, float] = {}
    if truths:
        truth_list = [truths.get(n) for n in names]
        if all(t is None for t in truth_list):
            truth_list = None
        else:
            for i, value in enumerate(truth_list):
                if value is None or not np.isfinite(value):
                    continue
                lo, hi = ranges[i]
                width = hi - lo
                if lo <= value <= hi:
                    continue
                if value >= lo - width and value <= hi + width:  # show it: widen the axis
                    margin = 0.05 * width
                    ranges[i] = (min(lo, value - margin), max(hi, value + margin))
                else:  # so far off that the posterior would shrink to a line: say so
                    off_scale[i] = float(value)
    corner.corner(
        samples, fig=fig, labels=[parameter_label(n) for n in names],
        range=ranges, quantiles=list(QUANTILES), show_titles=False, color=color, truths=truth_list,
        truth_color=next(c for c in (OKABE_ITO["vermillion"], OKABE_ITO["blue"]) if c != color),
        smooth=1.0 if n_draws >= 2000 else 1.6, smooth1d=None,
        bins=int(np.clip(np.sqrt(n_draws) / 2, 15, 30)), max_n_ticks=3,
        label_kwargs={"fontsize": 10},
        hist_kwargs={"lw": 1.2}, levels=(0.393, 0.865), plot_datapoints=True,
        data_kwargs={"alpha": 0.08, "ms": 1.2}, fill_contours=True, labelpad=0.08,
        use_math_text=True,
    )
    axes = np.asarray(fig.axes).reshape(k, k)
    for ax in axes[np.triu_indices(k, 1)]:
        # corner leaves the upper triangle empty (no frame, no ticks) but drawn: hidden, the
        # PNG is identical pixel for pixel and saving skips 28 of 64 axes (~50 ms).
        ax.set_visible(False)
    for i, name in enumerate(names):
        title = quantile_title(name, samples[:, i])
        if i in off_scale:
            arrow = "→" if off_scale[i] > ranges[i][1] else "←"
            title += f"\n(true value {off_scale[i]:g} off scale {arrow})"
        axes[i, i].set_title(title, fontsize=9)
    for ax in fig.axes:
        ax.tick_params(labelsize=8)
    quantiles = ", ".join(f"{100 * q:.0f}" for q in QUANTILES)
    title = (f"{model_name(model)} posterior ({n_draws} draws). Contours: 1σ and 2σ "
             f"regions; dashed lines: {quantiles} % quantiles")
    if truth_list is not None:
        title += "; solid lines: true values"
    title = textwrap.fill(title, width=int(size * 13))
    fig.suptitle(title, fontsize=10, y=0.995)
    top_margin = (0.3 + 0.18 * (title.count("\n") + 1) + (0.17 if 0 in off_scale else 0)) / size
    fig.subplots_adjust(top=1 - top_margin, left=1.05 / size, bottom=0.85 / size,
                        right=1 - 0.45 / size, wspace=0.06, hspace=0.06)
    return fig


def plot_corner(idata, path: str | os.PathLike[str], truths: dict[str, float] | None = None, *,
                overwrite: bool = False) -> Path:
    """Write ``corner.png`` (see :func:`draw_corner`) to ``path`` atomically."""
    with style():
        fig = draw_corner(idata, truths)
    return save_figure(fig, path, overwrite=overwrite)
