"""The figures of ``drumroll calibrate``: rank histograms and coverage (Talts et al. 2018).

``ranks.png``: one panel per quantity, the histogram of the truth's ranks among the posterior
draws with the band each bin stays inside with 99 % probability when the ranks are uniform
(grey, as Talts et al.'s figures draw it) and its expected count (a line). A ∪ says the
posterior is too narrow, a ∩ too wide, a slope that it is biased. With ``--audio`` the ranks
of the fits of the extractor's onsets are drawn over them as an outline.

``coverage.png``: the share of simulations whose central 50 % and 90 % intervals held the
truth, per quantity, with Clopper–Pearson error bars (68 %), against the nominal rate and the
band a calibrated coverage falls in with 99 % probability.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from drumroll.reporting.plot_style import (
    OKABE_ITO,
    new_figure,
    parameter_label,
    parameter_symbol,
)

#: Colours of the two calibrations.
LEVEL_COLORS = {"onsets": OKABE_ITO["blue"], "audio": OKABE_ITO["vermillion"]}
LEVEL_NAMES = {"onsets": "simulated onsets", "audio": "onsets the extractor found"}


def _keys(result: Any) -> list[str]:
    """Every calibrated quantity, parameters first."""
    return [*result.onsets.parameters, *result.onsets.derived]


def draw_ranks(result: Any):
    """The rank histograms of a :class:`~drumroll.calibration.CalibrationResult` (a
    :class:`matplotlib.figure.Figure`; see the module docstring)."""
    keys = _keys(result)
    columns = min(4, len(keys))
    rows = math.ceil(len(keys) / columns)
    fig = new_figure((3.0 * columns, 2.3 * rows + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, columns, squeeze=False)).ravel()
    levels = result.levels
    for ax, key in zip(axes, keys, strict=False):
        first = levels["onsets"].quantities[key]
        bins = len(first.histogram)
        width = first.n_ranks / bins
        edges = np.arange(bins + 1) * width
        low, high = first.band
        expected = first.n / bins
        ax.axhspan(low, high, color="0.88", lw=0, zorder=0)
        for edge in (low, high):  # the band's ends, seen over the bars too
            ax.axhline(edge, color="0.6", lw=0.6, ls=":", zorder=2.5)
        ax.axhline(expected, color="0.55", lw=0.8, zorder=1)
        ax.bar(edges[:-1], first.histogram, width=width, align="edge",
               color=OKABE_ITO["sky"], edgecolor="white", lw=0.4, zorder=2)
        title = [f"{parameter_symbol(key)}: p = {first.chi_square.p_value:.2g}"]
        if "audio" in levels and key in levels["audio"].quantities:
            heard = levels["audio"].quantities[key]
            ax.stairs(heard.histogram, edges, color=LEVEL_COLORS["audio"], lw=1.6, zorder=3)
            title.append(f"heard: {heard.chi_square.p_value:.2g}")
        ax.set_title(", ".join(title), fontsize=9.5,
                     color="black" if first.passed else OKABE_ITO["vermillion"])
        ax.set_xlim(0, first.n_ranks)
        ax.set_ylim(0, max(high, *first.histogram) * 1.15)
        ax.set_xlabel(f"rank of the true {parameter_label(key)}", fontsize=8.5)
    for ax in axes[len(keys):]:
        ax.set_visible(False)
    for ax in axes[::columns]:
        ax.set_ylabel("simulations")
    settings = result.settings
    key = "grey: where a bin falls with 99 % probability if calibrated"
    if "audio" in levels:
        key += "; filled: simulated onsets, outline: the extractor's"
    # Two lines: on one, the key ran past the figure's edges.
    fig.suptitle(f"Rank histograms, {settings.model} model ({settings.n} simulations, ranks "
                 f"among {settings.rank_draws} posterior draws)\n{key}", fontsize=10)
    return fig


def draw_coverage(result: Any):
    """The 50 % and 90 % coverage of a :class:`~drumroll.calibration.CalibrationResult` (a
    :class:`matplotlib.figure.Figure`; see the module docstring)."""
    keys = _keys(result)
    levels = result.levels
    fig = new_figure((8.6, 0.9 + 0.34 * len(keys)), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    y = np.arange(len(keys))[::-1].astype(float)
    offsets = {"onsets": 0.12, "audio": -0.12} if "audio" in levels else {"onsets": 0.0}
    for ax, nominal in zip(axes, (0.5, 0.9), strict=True):
        band = getattr(levels["onsets"].quantities[keys[0]], f"coverage_{round(nominal * 100)}")
        ax.axvspan(band.band_low, band.band_high, color="0.88", lw=0, zorder=0)
        ax.axvline(nominal, color="0.45", lw=0.9, ls="--", zorder=1)
        for name, level in levels.items():
            rates, lows, highs, ys = [], [], [], []
            for key, row in zip(keys, y, strict=True):
                if key not in level.quantities:
                    continue
                c = getattr(level.quantities[key], f"coverage_{round(nominal * 100)}")
                rates.append(c.rate)
                lows.append(c.rate - c.low)
                highs.append(c.high - c.rate)
                ys.append(row + offsets[name])
            ax.errorbar(rates, ys, xerr=[lows, highs], fmt="o", ms=4.5, capsize=2.5,
                        color=LEVEL_COLORS[name], elinewidth=1.2, label=LEVEL_NAMES[name],
                        zorder=3)
        # The band with room on both sides, so that it reads as a band.
        ends = [band.band_low, band.band_high, *(
            getattr(q, f"coverage_{round(nominal * 100)}").low for level in levels.values()
            for q in level.quantities.values()), *(
            getattr(q, f"coverage_{round(nominal * 100)}").high for level in levels.values()
            for q in level.quantities.values())]
        pad = 0.3 * (band.band_high - band.band_low)
        ax.set_xlim(max(0.0, min(ends) - pad), min(1.0, max(ends) + pad))
        ax.set_title(f"{nominal * 100:.0f} % central intervals (grey: 99 % band)",
                     fontsize=9.5)
        ax.set_xlabel("share holding the truth")
        ax.grid(True, axis="x", color="0.93", lw=0.6)
        ax.set_axisbelow(True)
    split = len(result.onsets.parameters)
    for ax in axes:
        if 0 < split < len(keys):
            ax.axhline(y[split - 1] - 0.5, color="0.7", lw=0.6)
    axes[0].set_yticks(y, [parameter_symbol(k) for k in keys])
    axes[0].set_ylim(-0.6, len(keys) - 0.4)
    if "audio" in levels:
        axes[1].legend(loc="lower left", fontsize=8)
    fig.suptitle(f"Coverage, {result.settings.model} model, {result.settings.n} simulations "
                 "(error bars: 68 % Clopper–Pearson)", fontsize=10)
    return fig
