"""Figure 5 of the paper: bounce-duration series of several set-ups, one panel per group.

Each run's observed flight times T_k (from its onsets, with ±1σ error bars from the onset
timing; none next to a bounce that was not heard) are drawn with its main model's posterior
median curve and 90 % band; the y axis is
logarithmic, where a power law is a straight line. Runs sharing a ``group`` key in the RUNS
file share a panel (the paper: two pivots | two heights | two drumhead tensions).

The inputs are the plain row data of :func:`drumroll.table.execute.compute_run` (lists of
numbers), so a cached table is redrawn without ArviZ or the posterior files.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from drumroll.inference.results import Summary
from drumroll.reporting.plot_style import (
    BAND,
    OKABE_ITO,
    model_name,
    new_figure,
    save_figure,
    style,
)

#: Run colours within a panel (the Okabe–Ito palette without yellow, which is hard to see).
RUN_COLORS = tuple(OKABE_ITO[c] for c in ("blue", "vermillion", "green", "orange", "purple",
                                          "sky", "black"))
_MARKERS = ("o", "s", "^", "D", "v", "P", "X")


def draw_figure5(panels: Sequence[tuple[str | None, Sequence[tuple[str, Summary]]]],
                 title: str | None = None):
    """Build the figure.

    Parameters
    ----------
    panels
        ``(panel title or None, [(run label, summary), …])`` per panel: each run's
        :class:`~drumroll.inference.results.Summary` gives its observed flights (None where a
        flight was not observed: the flights next to a missing bounce), the main model's
        flights (median and band) and its α.
    title
        Figure title (optional).
    """
    from matplotlib.ticker import FormatStrFormatter, LogLocator, MaxNLocator, NullFormatter

    n = len(panels)
    fig = new_figure((3.9 * n + 0.6, 4.3), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, n, sharey=True, squeeze=False)[0])
    models = set()
    for ax, (panel_title, runs) in zip(axes, panels, strict=True):
        for j, (label, row) in enumerate(runs):
            color, marker = RUN_COLORS[j % len(RUN_COLORS)], _MARKERS[j % len(_MARKERS)]
            flights = row.models[row.model].flights
            observed = np.array([np.nan if v is None else v
                                 for v in row.observed_flights.time_s], float)
            err = np.array([np.nan if v is None else v for v in row.observed_flights.err_s],
                           float)
            lo, mid, hi = (np.asarray(getattr(flights, k), float)
                           for k in ("low", "median", "high"))
            count = min(observed.size, mid.size)
            k = np.arange(1, count + 1)
            ax.fill_between(k, lo[:count], hi[:count], color=color, alpha=0.2, lw=0, zorder=1)
            ax.plot(k, mid[:count], color=color, lw=1.4, zorder=2)
            alpha = row.parameters.get("alpha")
            text = label
            if alpha is not None and alpha.mean is not None and alpha.sd is not None:
                from drumroll.reporting.numbers import format_value_error

                text += f" (α = {format_value_error(alpha.mean, alpha.sd)})"
            ax.errorbar(k, observed[:count], yerr=err[:count], fmt=marker, ms=4, color=color,
                        mfc="white", mew=1.1, elinewidth=0.9, capsize=0, zorder=3, label=text)
            models.add(row.model)
        ax.set_yscale("log")
        ax.set_xlabel("bounce number $k$")
        if panel_title:
            ax.set_title(panel_title)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, steps=[1, 2, 5, 10]))
        ax.grid(True, which="major", color="0.9", lw=0.6)
        ax.grid(True, which="minor", axis="y", color="0.95", lw=0.4)
        ax.set_axisbelow(True)
        ax.legend(loc="lower left", handlelength=1.6)
    axes[0].set_ylabel("flight time $T_k$ (s)")
    axes[0].yaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    axes[0].yaxis.set_major_formatter(FormatStrFormatter("%g"))
    axes[0].yaxis.set_minor_locator(LogLocator(base=10.0, subs=(3.0, 4.0, 6.0, 7.0, 8.0, 9.0)))
    axes[0].yaxis.set_minor_formatter(NullFormatter())
    names = ", ".join(model_name(m) for m in sorted(models))
    fig.suptitle(title or f"Bounce duration series: data, {names} posterior median and "
                 f"{BAND:.0%} band", fontsize=10.5)
    return fig


def plot_figure5(panels: Sequence[tuple[str | None, Sequence[tuple[str, Summary]]]],
                 path: str | os.PathLike[str], *, title: str | None = None,
                 overwrite: bool = False) -> Path:
    """Write Figure 5 (see :func:`draw_figure5`) to ``path`` as a PNG, atomically."""
    with style():
        fig = draw_figure5(panels, title)
    return save_figure(fig, path, overwrite=overwrite)
