"""The model comparison at a glance: PSIS-LOO elpd and, when available, log Bayes factors.

Left panel (after ``arviz.plot_compare``): each model's expected log predictive density
(elpd_loo, higher is better) with its standard error, and for the other models a grey
triangle with the standard error of their difference from the main model (the one that
matters: the models are judged on the same onsets, so their errors are correlated). Right
panel, if there are evidences: the log Bayes factor of the main model over each other, with
its error, the band |ln B| < 1 (not worth more than a bare mention, Kass & Raftery 1995)
shaded.

Signs are the summary's (:class:`~drumroll.inference.results.ComparisonRow`): every
difference is *main model − other model*, so positive favours the main model.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from drumroll.inference.results import ComparisonRow, LooSummary
from drumroll.reporting.numbers import format_value_error
from drumroll.reporting.plot_style import (
    model_color,
    model_name,
    new_figure,
    ordered_models,
    save_figure,
    style,
)


def _number(value: float | None) -> float:
    """A float, NaN for None."""
    return math.nan if value is None else float(value)


def _text(value: float, err: float) -> str:
    """``value ± err`` rounded to the error, with a typographic minus sign."""
    text = format_value_error(value, err) if math.isfinite(err) and err > 0 else f"{value:.1f}"
    return text.replace("-", "−")


def draw_comparison(rows: Sequence[ComparisonRow], loo: Mapping[str, LooSummary],
                    main_model: str):
    """Build the comparison figure (a :class:`matplotlib.figure.Figure`).

    Parameters
    ----------
    rows
        The main model against each other one (main − other).
    loo
        Every model's PSIS-LOO (elpd and its standard error), the main model's included.
    main_model
        The reference model (drawn on top, dashed line at its elpd).
    """
    others = {row.model: row for row in rows}
    if not others:
        raise ValueError("nothing to compare: no other model was fitted")
    models = ordered_models([main_model, *others], main_model)
    elpd = {m: _number(loo[m].elpd_loo) if m in loo else math.nan for m in models}
    se = {m: _number(loo[m].elpd_loo_se) if m in loo else math.nan for m in models}
    diff = {m: _number(r.elpd_loo_diff) for m, r in others.items()}
    dse = {m: _number(r.elpd_loo_diff_se) for m, r in others.items()}
    lnb = {m: _number(r.log_bayes_factor) for m, r in others.items()}
    lnb_err = {m: _number(r.log_bayes_factor_err) for m, r in others.items()}
    has_bayes = any(math.isfinite(v) for v in lnb.values())
    has_elpd = any(math.isfinite(v) for v in elpd.values())

    n_panels = int(has_elpd) + int(has_bayes)
    if n_panels == 0:
        raise ValueError("the comparison has neither elpd_loo nor log Bayes factors to draw")
    fig = new_figure((4.2 * n_panels + 1.6, 0.9 + 0.62 * len(models)), layout="constrained")
    axes = list(np.atleast_1d(fig.subplots(1, n_panels, sharey=True, squeeze=False)[0]))
    y = {m: len(models) - 1 - i for i, m in enumerate(models)}  # main model on top

    if has_elpd:
        ax = axes.pop(0)
        main_elpd = elpd.get(main_model, math.nan)
        if math.isfinite(main_elpd):
            ax.axvline(main_elpd, color="0.5", lw=0.8, ls="--", zorder=1)
        for i, m in enumerate(models):
            if not math.isfinite(elpd[m]):
                continue
            color = model_color(m, i)
            if m != main_model and math.isfinite(dse[m]) and dse[m] > 0:
                ax.errorbar(elpd[m], y[m] - 0.22, xerr=dse[m], fmt="^", ms=5, color="0.45",
                            elinewidth=1.2, capsize=3, zorder=2)
            ax.errorbar(elpd[m], y[m], xerr=se[m] if math.isfinite(se[m]) else None, fmt="o",
                        ms=7, color=color, elinewidth=1.6, capsize=3, zorder=3)
            label = _text(elpd[m], se[m])
            if m != main_model and math.isfinite(diff[m]):
                label += f"   main − this = {_text(diff[m], dse[m])}"
            ax.annotate(label, (elpd[m], y[m]), xytext=(0, 9), textcoords="offset points",
                        ha="center", va="bottom", fontsize=8.5)
        ax.set_xlabel("elpd_loo\n(log predictive density, higher is better)")
        title = "PSIS-LOO: ● elpd ± SE"
        if any(math.isfinite(dse[m]) and dse[m] > 0 for m in models if m != main_model):
            title += f",  ▲ ± SE of the difference from {model_name(main_model)}"
        ax.set_title(title, fontsize=9.5)
        _pad_x(ax, [elpd[m] - (se[m] if math.isfinite(se[m]) else 0) for m in models],
               [elpd[m] + (se[m] if math.isfinite(se[m]) else 0) for m in models])

    if has_bayes:
        ax = axes.pop(0)
        ax.axvspan(-1, 1, color="0.92", lw=0, zorder=0)
        ax.axvline(0.0, color="0.5", lw=0.8, ls="--", zorder=1)
        lnb[main_model], lnb_err[main_model] = 0.0, math.nan
        for i, m in enumerate(models):
            if not math.isfinite(lnb[m]):
                continue
            err = lnb_err[m] if math.isfinite(lnb_err[m]) else None
            ax.errorbar(lnb[m], y[m], xerr=err, fmt="s", ms=6.5, color=model_color(m, i),
                        elinewidth=1.6, capsize=3, zorder=3)
            if m != main_model:
                ax.annotate(_text(lnb[m], lnb_err[m]), (lnb[m], y[m]), xytext=(0, 9),
                            textcoords="offset points", ha="center", va="bottom",
                            fontsize=8.5)
        ax.set_xlabel(f"ln B = ln Z({model_name(main_model)}) − ln Z(model)\n"
                      "(positive favours the main model)")
        ax.set_title("Bayes factor (grey: |ln B| < 1, inconclusive)", fontsize=9.5)
        finite = [v for v in lnb.values() if math.isfinite(v)]
        errs = [lnb_err[m] if math.isfinite(lnb_err[m]) else 0 for m in models
                if math.isfinite(lnb[m])]
        _pad_x(ax, [min(-1.5, *(v - e for v, e in zip(finite, errs, strict=True)))],
               [max(1.5, *(v + e for v, e in zip(finite, errs, strict=True)))])

    first = fig.axes[0]
    first.set_yticks([y[m] for m in models], [model_name(m) + (" (main)" if m == main_model
                                                              else "") for m in models])
    for i, label in enumerate(first.get_yticklabels()):
        label.set_color(model_color(models[i], i))
    first.set_ylim(-0.6, len(models) - 0.35)
    for ax in fig.axes:
        ax.grid(True, axis="x", color="0.92", lw=0.6)
        ax.set_axisbelow(True)
        ax.tick_params(axis="y", length=0)
    return fig


def _pad_x(ax, lows: list[float], highs: list[float], fraction: float = 0.2) -> None:
    """Set x limits around the finite values with some room for the labels."""
    lo = min((v for v in lows if math.isfinite(v)), default=math.nan)
    hi = max((v for v in highs if math.isfinite(v)), default=math.nan)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return
    width = hi - lo if hi > lo else max(abs(hi), 1.0)
    ax.set_xlim(lo - fraction * width, hi + fraction * width)


def plot_comparison(rows: Sequence[ComparisonRow], loo: Mapping[str, LooSummary],
                    main_model: str, path: str | os.PathLike[str], *,
                    overwrite: bool = False) -> Path:
    """Write ``comparison.png`` (see :func:`draw_comparison`) to ``path`` atomically."""
    with style():
        fig = draw_comparison(rows, loo, main_model)
    return save_figure(fig, path, overwrite=overwrite)
