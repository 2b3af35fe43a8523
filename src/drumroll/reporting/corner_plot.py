"""The corner plot of the main model's posterior, drawn as corner.py draws it.

Every sampled parameter plus t_B, with units in the labels, the 5, 50 and 95 % quantiles
marked on the marginals, a title ``median +up −down`` rounded to its error, and the true
values overlaid when they are known (simulations). The 2-D panels show the posterior's
correlations: in the small-angle model the pivot, the height and the release speed lie along
a ridge; the exact pendulum narrows it through the curvature of the bounce series.

The panels are corner.py's (Foreman-Mackey 2016: a smoothed 2-D histogram, filled 1σ and 2σ
regions over the draws outside them, step-histogram marginals), drawn here with matplotlib
alone: corner.py imports ArviZ (a second of CPU, which the estimate otherwise does without)
and draws the empty upper triangle and each region's white base as artists of their own.
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


#: Probability mass inside the 2-D contours: a 2-D Gaussian's 1σ and 2σ regions.
LEVELS = (0.393, 0.865)
#: Ticks per axis (at most), and the labels' offset below / left of the panels (axes units).
MAX_TICKS = 3
LABEL_OFFSET = 0.38


def _contour_levels(density: np.ndarray, masses: tuple[float, ...]) -> np.ndarray:
    """The density above which each of ``masses`` lies, ascending (corner.py's rule)."""
    flat = np.sort(density.ravel())[::-1]
    cumulative = np.cumsum(flat)
    cumulative /= cumulative[-1]
    levels = np.array([flat[cumulative <= m][-1] if np.any(cumulative <= m) else flat[0]
                       for m in masses])
    levels.sort()
    while np.any(np.diff(levels) == 0):  # too few draws: nudge ties apart
        levels[np.flatnonzero(np.diff(levels) == 0)[0]] *= 1.0 - 1e-4
        levels.sort()
    return levels


def _padded_grid(edges_x: np.ndarray, edges_y: np.ndarray, density: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bin centres and the density extended by two bins on every side (its edge values,
    then its minimum), so that contours close at the panel's edges (corner.py's rule)."""
    def centres(edges: np.ndarray) -> np.ndarray:
        mid = 0.5 * (edges[1:] + edges[:-1])
        step = mid[1] - mid[0]
        return np.concatenate([mid[0] + np.array([-2.0, -1.0]) * step, mid,
                               mid[-1] + np.array([1.0, 2.0]) * step])

    padded = np.full((density.shape[0] + 4, density.shape[1] + 4), density.min())
    padded[1:-1, 1:-1] = np.pad(density, 1, mode="edge")
    return centres(edges_x), centres(edges_y), padded


def _blend(color: str, alpha: float) -> tuple[float, float, float]:
    """``color`` at opacity ``alpha`` over white, as one opaque colour."""
    from matplotlib.colors import to_rgb

    return tuple(1.0 - alpha * (1.0 - c) for c in to_rgb(color))


def _panel_2d(ax, x: np.ndarray, y: np.ndarray, ranges: tuple, bins: int, smooth: float,
              color: str) -> None:
    """One 2-D panel: the draws as faint points, the smoothed histogram's 1σ and 2σ regions
    filled (inner in ``color``, outer at a third of it, both opaque so that the points under
    them are hidden: corner.py's white base and translucent fills in one artist) and
    outlined."""
    from scipy.ndimage import gaussian_filter

    (x_lo, x_hi), (y_lo, y_hi) = ranges
    counts, edges_x, edges_y = np.histogram2d(
        x, y, bins=[np.linspace(x_lo, x_hi, bins + 1), np.linspace(y_lo, y_hi, bins + 1)])
    density = gaussian_filter(counts, smooth)
    levels = _contour_levels(density, LEVELS)
    grid_x, grid_y, padded = _padded_grid(edges_x, edges_y, density)
    ax.plot(x, y, "o", zorder=-1, rasterized=True, color=color, ms=1.2, alpha=0.08, mec="none")
    ax.contourf(grid_x, grid_y, padded.T, [*levels, density.max() * (1 + 1e-4)],
                colors=[_blend(color, 1.0 / 3.0), color], antialiased=False)
    ax.contour(grid_x, grid_y, padded.T, levels, colors=color)
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)


def _format_axes(axes: np.ndarray, labels: list[str]) -> None:
    """Ticks (at most :data:`MAX_TICKS`, the lowest pruned), tick labels on the outer panels
    only, rotated by 45°, and the parameter labels below and left of the grid."""
    from matplotlib.ticker import MaxNLocator, NullLocator

    # The tick labels keep the axes' own plain-text formatter: mathtext's (useMathText)
    # parsed each label on its own, a tenth of the figure's time (medians of 12 cold
    # draws), for the same digits in the same font; only an axis that needs an exponent
    # shows it as 1e−5, not ×10⁻⁵.
    k = len(labels)
    for i in range(k):
        for j in range(i + 1):
            ax = axes[i, j]
            ax.xaxis.set_major_locator(MaxNLocator(MAX_TICKS, prune="lower"))
            if i == j:
                ax.yaxis.set_major_locator(NullLocator())
                ax.set_yticklabels([])
            else:
                ax.yaxis.set_major_locator(MaxNLocator(MAX_TICKS, prune="lower"))
            if i < k - 1:
                ax.tick_params(axis="x", labelbottom=False)
            else:
                ax.tick_params(axis="x", labelrotation=45)
                ax.set_xlabel(labels[j], fontsize=10)
                ax.xaxis.set_label_coords(0.5, -LABEL_OFFSET)
            if i == j:
                continue
            if j > 0:
                ax.tick_params(axis="y", labelleft=False)
            else:
                ax.tick_params(axis="y", labelrotation=45)
                ax.set_ylabel(labels[i], fontsize=10)
                ax.yaxis.set_label_coords(-LABEL_OFFSET, 0.5)
            ax.tick_params(labelsize=8)
        axes[i, i].tick_params(labelsize=8)


def draw_corner(idata, truths: dict[str, float] | None = None):
    """Build the corner figure (a :class:`matplotlib.figure.Figure`) of ``idata``'s posterior.

    Parameters
    ----------
    idata
        One model's draws (:class:`~drumroll.inference.draws.Draws` or InferenceData).
    truths
        Known parameter values by posterior name (e.g. ``{"alpha": 0.88, "pivot_mm": 131}``);
        names that are not plotted are ignored.
    """
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
    bins = int(np.clip(np.sqrt(n_draws) / 2, 15, 30))
    smooth = 1.0 if n_draws >= 2000 else 1.6
    # The lower triangle only: the upper one would be empty (axes cost ~10 ms each).
    grid = fig.add_gridspec(k, k)
    axes = np.full((k, k), None, dtype=object)
    for i in range(k):
        for j in range(i + 1):
            axes[i, j] = fig.add_subplot(grid[i, j])
    for i in range(k):
        ax = axes[i, i]
        counts, _, _ = ax.hist(samples[:, i], bins=np.linspace(*ranges[i], bins + 1),
                               histtype="step", color=color, lw=1.2)
        for value in np.percentile(samples[:, i], [100.0 * q for q in QUANTILES]):
            ax.axvline(value, ls="dashed", color=color)
        ax.set_xlim(*ranges[i])
        ax.set_ylim(0, 1.1 * np.max(counts))
        for j in range(i):
            _panel_2d(axes[i, j], samples[:, j], samples[:, i], (ranges[j], ranges[i]), bins,
                      smooth, color)
    _format_axes(axes, [parameter_label(n) for n in names])
    if truth_list is not None:
        truth_color = next(c for c in (OKABE_ITO["vermillion"], OKABE_ITO["blue"])
                           if c != color)
        for i, value in enumerate(truth_list):
            if value is not None:
                axes[i, i].axvline(value, color=truth_color)
            for j in range(i):
                if truth_list[j] is not None:
                    axes[i, j].axvline(truth_list[j], color=truth_color)
                if value is not None:
                    axes[i, j].axhline(value, color=truth_color)
                if value is not None and truth_list[j] is not None:
                    axes[i, j].plot(truth_list[j], value, "s", color=truth_color)
    for i, name in enumerate(names):
        title = quantile_title(name, samples[:, i])
        if i in off_scale:
            arrow = "→" if off_scale[i] > ranges[i][1] else "←"
            title += f"\n(true value {off_scale[i]:g} off scale {arrow})"
        axes[i, i].set_title(title, fontsize=9)
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
