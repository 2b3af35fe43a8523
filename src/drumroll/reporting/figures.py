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

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

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


def load_figure_libraries() -> None:
    """Import what drawing needs (matplotlib's Agg canvas, corner, ArviZ), e.g. while the
    models are sampled, so that the figures' worker processes, forked afterwards, share it
    rather than each importing it again (about a second each)."""
    import corner  # noqa: F401  (it imports ArviZ)
    from matplotlib.backends import backend_agg  # noqa: F401
    from matplotlib.figure import Figure  # noqa: F401


def loo_comparison(idatas: dict[str, Any], main_model: str,
                   summary_rows: list[dict[str, Any]] | None = None,
                   loos: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Rows for the comparison figure: every model's elpd and its difference from the main one.

    The figure shows differences as *model − main*; ``summary.json`` (and
    :func:`drumroll.inference.comparison.compare_models`) signs them *main − model*. This
    turns the latter into the former. PSIS-LOO is computed here only when ``loos`` (model →
    :class:`~drumroll.inference.comparison.LooResult`, as ``estimate`` already has them) and
    the summary rows are not both given.
    """
    from drumroll.inference.comparison import compare_models

    if loos is None or summary_rows is None:
        rows, _, _, loos = compare_models(idatas, main_model)
    else:
        rows = summary_rows
    given = {str(r["model"]): r for r in (summary_rows or rows)}
    out: list[dict[str, Any]] = [{"model": main_model, "elpd_loo": loos[main_model].elpd,
                                  "elpd_loo_se": loos[main_model].se, "elpd_loo_diff": 0.0,
                                  "elpd_loo_diff_se": 0.0, "log_bayes_factor": 0.0,
                                  "log_bayes_factor_err": 0.0}]
    for row in rows:
        model = str(row["model"])
        source = given.get(model, row)
        plot_row = {"model": model, "elpd_loo": loos[model].elpd, "elpd_loo_se": loos[model].se,
                    "elpd_loo_diff": -float(source["elpd_loo_diff"]),
                    "elpd_loo_diff_se": float(source["elpd_loo_diff_se"])}
        if source.get("log_bayes_factor") is not None:
            plot_row["log_bayes_factor"] = -float(source["log_bayes_factor"])
            plot_row["log_bayes_factor_err"] = float(source["log_bayes_factor_err"])
        out.append(plot_row)
    return out


def write_figures(idatas: dict[str, Any], main_model: str, out_dir: str | os.PathLike[str],
                  comparison: list[dict[str, Any]] | None = None,
                  truths: dict[str, float] | None = None, overwrite: bool = False,
                  loos: dict[str, Any] | None = None) -> dict[str, Path]:
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
        The summary's comparison rows (``model``, ``elpd_loo_diff``, ``elpd_loo_diff_se``,
        ``log_bayes_factor``, ``log_bayes_factor_err``; signed *main − model*), or None to
        compute PSIS-LOO here.
    truths
        Known parameter values (simulations), by posterior name, for the corner plot.
    overwrite
        Replace existing files (the command line's ``--force``).
    loos
        The PSIS-LOO of each model when already computed (``Result.loos``).

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

    return {key: function(*args, **kwargs) for key, (function, args, kwargs)
            in figure_jobs(idatas, main_model, paths, comparison, truths, overwrite,
                           loos).items()}


#: One figure to draw: a module-level plotting function and its arguments (picklable, so a
#: process pool can draw figures side by side).
FigureJob = tuple[Callable[..., Path], tuple, dict[str, Any]]


def figure_jobs(idatas: dict[str, Any], main_model: str, paths: dict[str, Path],
                comparison: list[dict[str, Any]] | None = None,
                truths: dict[str, float] | None = None, overwrite: bool = False,
                loos: dict[str, Any] | None = None) -> dict[str, FigureJob]:
    """The figures of :func:`write_figures` as jobs, slowest first; ``paths`` maps each key of
    :data:`FIGURE_FILES` to its file. Nothing is drawn yet: call ``function(*args,
    **kwargs)``, here or in another process."""
    main = idatas[main_model]
    rows = loo_comparison(idatas, main_model, comparison, loos)
    jobs: dict[str, FigureJob] = {
        "corner": (plot_corner, (main, paths["corner"], truths), {"overwrite": overwrite}),
        "trace": (plot_trace, (main, paths["trace"]), {"overwrite": overwrite}),
        "bounce_series": (plot_bounce_series, (idatas, main_model, paths["bounce_series"]),
                          {"overwrite": overwrite}),
        "residuals": (plot_residuals, (idatas, paths["residuals"], main_model),
                      {"overwrite": overwrite}),
    }
    if rows:
        jobs["comparison"] = (plot_comparison, (rows, main_model, paths["comparison"]),
                              {"overwrite": overwrite})
    return jobs
