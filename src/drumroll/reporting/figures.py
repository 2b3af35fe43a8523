"""All figures of ``drumroll estimate`` in one call.

:func:`write_figures` writes, into one folder,

* ``bounce_series.png``: flight time against bounce number with every model's posterior
  median and 90 % band, and the differences from the main model (after the paper's Fig. 5);
* ``corner.png``: the main model's posterior (corner.py), true values overlaid if known;
* ``trace.png``: the main model's walkers and marginals, with R-hat and ESS;
* ``residuals.png``: the posterior predictive check of onset times, one panel per model;
* ``comparison.png``: PSIS-LOO elpd per model and, when given, log Bayes factors.

The onset figure is made by :mod:`drumroll.reporting.onset_plot`. Each file is written
atomically; existing files are refused (all of them checked before anything is drawn) unless
``overwrite`` is set.
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from drumroll import fileio
from drumroll.errors import DrumrollError
from drumroll.reporting.bounce_series import plot_bounce_series
from drumroll.reporting.comparison_plot import plot_comparison
from drumroll.reporting.corner_plot import plot_corner
from drumroll.reporting.residuals import plot_residuals
from drumroll.reporting.trace_plot import plot_trace

#: Figure key → file name (the keys are those of the dict :func:`write_figures` returns).
FIGURE_FILES: dict[str, str] = {
    "bounce_series": "bounce_series.png",
    "corner": "corner.png",
    "trace": "trace.png",
    "residuals": "residuals.png",
    "comparison": "comparison.png",
}


def loo_comparison(idatas: dict[str, Any], main_model: str) -> list[dict[str, float | str]]:
    """PSIS-LOO elpd of every model and its difference from ``main_model``.

    Differences are *model − main* (negative: worse than the main model); their standard
    error comes from the pointwise differences, as in :func:`arviz.compare`. Models without a
    usable ``log_likelihood`` group are left out.
    """
    import arviz as az

    loos = {}
    for model, idata in idatas.items():
        if "log_likelihood" not in idata.groups():
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                loos[model] = az.loo(idata, pointwise=True)
            except Exception:  # not enough draws, all -inf, …: just leave the model out
                continue
    rows: list[dict[str, float | str]] = []
    reference = loos.get(main_model)
    for model, loo in loos.items():
        row: dict[str, float | str] = {"model": model, "elpd_loo": float(loo.elpd_loo),
                                       "elpd_loo_se": float(loo.se)}
        if reference is not None:
            diff = np.asarray(loo.loo_i) - np.asarray(reference.loo_i)
            if diff.size == np.asarray(reference.loo_i).size:
                row["elpd_loo_diff"] = float(np.sum(diff))
                row["elpd_loo_diff_se"] = float(np.sqrt(diff.size * np.var(diff)))
        rows.append(row)
    return rows


def _merge(given: list[dict[str, Any]] | None, computed: list[dict[str, Any]]
           ) -> list[dict[str, Any]]:
    """The caller's rows, with missing elpd numbers filled in from ``computed``."""
    if not given:
        return computed
    by_model = {str(r["model"]): r for r in computed}
    merged = []
    for row in given:
        row = dict(row)
        extra = by_model.get(str(row.get("model")), {})
        for key in ("elpd_loo", "elpd_loo_se", "elpd_loo_diff_se"):
            value = row.get(key)
            if value is None or (isinstance(value, float) and math.isnan(value)):
                if key in extra:
                    row[key] = extra[key]
        merged.append(row)
    return merged


def write_figures(idatas: dict[str, Any], main_model: str, out_dir: str | os.PathLike[str],
                  comparison: list[dict[str, Any]] | None = None,
                  truths: dict[str, float] | None = None, overwrite: bool = False
                  ) -> dict[str, Path]:
    """Write the five figures of an estimate into ``out_dir``.

    Parameters
    ----------
    idatas
        Model name → :class:`arviz.InferenceData` (as built by
        :func:`drumroll.inference.inference_data.build_inference_data`).
    main_model
        The model of the corner and trace plots and the reference of the comparisons.
    out_dir
        Existing folder to write into.
    comparison
        Rows ``{"model", "elpd_loo", "elpd_loo_se", "elpd_loo_diff", "elpd_loo_diff_se",
        "log_bayes_factor", "log_bayes_factor_err"}`` (main model included). Differences
        and ``log_bayes_factor`` (= ln Z(model) − ln Z(main)) are *model − main*. Missing
        elpd numbers are computed with :func:`arviz.loo`; None computes them all.
    truths
        Known parameter values (simulations), by posterior name, for the corner plot.
    overwrite
        Replace existing files (the command line's ``--force``).

    Returns
    -------
    dict
        Figure key (see :data:`FIGURE_FILES`) → path written.

    Raises
    ------
    drumroll.errors.DrumrollError
        If ``main_model`` is not among ``idatas``, ``out_dir`` is not a folder, or a figure
        file exists and ``overwrite`` is false (checked before anything is written).
    """
    if main_model not in idatas:
        raise DrumrollError(f"main model {main_model!r} was not fitted "
                            f"(fitted: {', '.join(idatas) or 'none'})")
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise DrumrollError(f"{out_dir}: no such directory")
    paths = {key: out_dir / name for key, name in FIGURE_FILES.items()}
    for path in paths.values():
        fileio.check_writable(path, overwrite=overwrite)

    main = idatas[main_model]
    rows = _merge(comparison, loo_comparison(idatas, main_model))
    written: dict[str, Path] = {}
    written["bounce_series"] = plot_bounce_series(idatas, main_model, paths["bounce_series"],
                                                  overwrite=overwrite)
    written["corner"] = plot_corner(main, paths["corner"], truths, overwrite=overwrite)
    written["trace"] = plot_trace(main, paths["trace"], overwrite=overwrite)
    written["residuals"] = plot_residuals(idatas, paths["residuals"], main_model,
                                          overwrite=overwrite)
    if rows:
        written["comparison"] = plot_comparison(rows, main_model, paths["comparison"],
                                                overwrite=overwrite)
    return written
