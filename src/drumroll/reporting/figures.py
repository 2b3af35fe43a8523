"""The figures of ``drumroll estimate``, registered once each: file, caption, drawing.

Every figure is a :class:`Figure` in :data:`FIGURES`, in the order the report shows them:

* ``onsets.png``: the recording with every onset (after the paper's Figure 4), when the
  source is audio;
* ``bounce_series.png``: flight time against bounce number with every model's posterior
  median and 90 % band, and the differences from the main model (after the paper's Fig. 5);
* ``residuals.png``: the posterior predictive check of onset times, one panel per model;
* ``comparison.png``: PSIS-LOO elpd per model and the log Bayes factors, when there is
  another model;
* ``corner.png``: the main model's posterior (corner.py), true values overlaid if known;
* ``trace.png``: the main model's walkers and marginals, with R-hat and ESS.

A figure draws what it is given (:class:`FigureInputs`: the fits and the summary) and
computes no statistic of its own. Each file is written atomically; :meth:`Figure.build`
gives the same figure as a :class:`matplotlib.figure.Figure` in memory (a notebook shows it
inline: ``result.figure("corner")``). Adding a figure is one module with its
``draw``/``plot`` functions and one :class:`Figure` line here.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drumroll import fileio
from drumroll.errors import DrumrollError
from drumroll.inference.results import Summary
from drumroll.reporting.bounce_series import draw_bounce_series, plot_bounce_series
from drumroll.reporting.comparison_plot import draw_comparison, plot_comparison
from drumroll.reporting.corner_plot import draw_corner, plot_corner
from drumroll.reporting.onset_plot import draw_onset_figure, write_onset_plot
from drumroll.reporting.plot_style import style
from drumroll.reporting.residuals import draw_residuals, plot_residuals
from drumroll.reporting.trace_plot import draw_trace, plot_trace


@dataclass(frozen=True)
class FigureInputs:
    """What the figures are given (picklable: they are drawn in worker processes).

    Attributes
    ----------
    idatas
        Model name → InferenceData (draws thinned as stored), main model first.
    summary
        The estimate's summary: the main model, its parameter summaries (R-hat and ESS of
        every draw), the comparison rows, each model's PSIS-LOO, the sampler targets.
    truths
        Known values by quantity key (simulations), for the corner plot.
    audio
        The recording the onsets came from (None: they came from a file).
    onsets
        The onset table of the recording (every roll), for the onset figure.
    """

    idatas: dict[str, Any]
    summary: Summary
    truths: dict[str, float] | None = None
    audio: str | os.PathLike[str] | None = None
    onsets: Any = None

    @property
    def main(self) -> str:
        """The main model."""
        return self.summary.model


@dataclass(frozen=True)
class Figure:
    """One figure: its file, its caption and what to look for in it (the report's), the
    function that draws it into its file (module level, so a process pool can call it), the
    one that builds it in memory, and when it applies."""

    key: str
    file: str
    caption: str
    note: str
    draw: Callable[[FigureInputs, Path, bool], Path]
    make: Callable[[FigureInputs], Any]
    applies: Callable[[FigureInputs], bool] = lambda inputs: True

    def build(self, inputs: FigureInputs):
        """The figure as a :class:`matplotlib.figure.Figure` (the one its file shows)."""
        return self.make(inputs)


def _onsets(inputs: FigureInputs, path: Path, overwrite: bool) -> Path:
    return write_onset_plot(path, inputs.audio, inputs.onsets, overwrite=overwrite)


def _bounce_series(inputs: FigureInputs, path: Path, overwrite: bool) -> Path:
    return plot_bounce_series(inputs.summary, path, overwrite=overwrite)


def _residuals(inputs: FigureInputs, path: Path, overwrite: bool) -> Path:
    return plot_residuals(inputs.summary, path, overwrite=overwrite)


def _comparison(inputs: FigureInputs, path: Path, overwrite: bool) -> Path:
    return plot_comparison(inputs.summary.comparison, inputs.summary.loo, inputs.main, path,
                           overwrite=overwrite)


def _corner(inputs: FigureInputs, path: Path, overwrite: bool) -> Path:
    return plot_corner(inputs.idatas[inputs.main], path, inputs.truths, overwrite=overwrite)


def _trace(inputs: FigureInputs, path: Path, overwrite: bool) -> Path:
    diagnostics = inputs.summary.diagnostics.get(inputs.main)
    return plot_trace(inputs.idatas[inputs.main], inputs.summary.parameters, path,
                      max_r_hat=diagnostics.max_r_hat if diagnostics else 1.01,
                      overwrite=overwrite)


def _styled(draw: Callable[..., Any], *args: Any) -> Any:
    with style():
        return draw(*args)


def _onsets_figure(inputs: FigureInputs) -> Any:
    return draw_onset_figure(inputs.audio, inputs.onsets)


def _bounce_series_figure(inputs: FigureInputs) -> Any:
    return _styled(draw_bounce_series, inputs.summary)


def _residuals_figure(inputs: FigureInputs) -> Any:
    return _styled(draw_residuals, inputs.summary)


def _comparison_figure(inputs: FigureInputs) -> Any:
    return _styled(draw_comparison, inputs.summary.comparison, inputs.summary.loo, inputs.main)


def _corner_figure(inputs: FigureInputs) -> Any:
    return _styled(draw_corner, inputs.idatas[inputs.main], inputs.truths)


def _trace_figure(inputs: FigureInputs) -> Any:
    diagnostics = inputs.summary.diagnostics.get(inputs.main)
    return _styled(draw_trace, inputs.idatas[inputs.main], inputs.summary.parameters,
                   diagnostics.max_r_hat if diagnostics else 1.01)


#: Every figure, by key, in the report's order.
FIGURES: dict[str, Figure] = {f.key: f for f in (
    Figure("onsets", "onsets.png", "Detected onsets",
           "The recording with every detected impact; check that none is missing or "
           "spurious.", _onsets, _onsets_figure, lambda inputs: inputs.audio is not None),
    Figure("bounce_series", "bounce_series.png", "Bounce series",
           "Flight time against bounce number with each model's posterior median and 90 % "
           "band; the lower panel shows the differences from the main model, where exact and "
           "small-angle pendulum part.", _bounce_series, _bounce_series_figure),
    Figure("residuals", "residuals.png", "Onset residuals",
           "Observed minus predicted onset times with the 90 % posterior predictive band. "
           "Random scatter: the model is adequate. A smooth pattern: the model, not the "
           "microphone, is the limit.", _residuals, _residuals_figure),
    Figure("comparison", "comparison.png", "Model comparison",
           "PSIS-LOO expected log predictive density per model (higher is better) and the log "
           "Bayes factors of the main model over the others.", _comparison, _comparison_figure,
           lambda inputs: bool(inputs.summary.comparison)),
    Figure("corner", "corner.png", "Posterior",
           "One- and two-dimensional marginals of the main model's parameters; tilted "
           "ellipses are correlations (the pivot-height-release-speed ridge).", _corner,
           _corner_figure),
    Figure("trace", "trace.png", "Sampler trace",
           "Walkers after burn-in; they should look like stationary noise around a common "
           "level.", _trace, _trace_figure),
)}
#: Roughly how long each figure takes to draw (s, the README's roll): the slowest are drawn
#: first, so that parallel workers finish together.
DRAW_SECONDS = {"corner": 1.3, "trace": 0.8, "residuals": 0.4, "onsets": 0.35,
                "bounce_series": 0.25, "comparison": 0.15}


def figure_files(inputs: FigureInputs) -> dict[str, str]:
    """Key → file name of every figure that applies to ``inputs``."""
    return {key: f.file for key, f in FIGURES.items() if f.applies(inputs)}


def write_figures(inputs: FigureInputs, out_dir: str | os.PathLike[str],
                  overwrite: bool = False) -> dict[str, Path]:
    """Draw every figure that applies into ``out_dir``, in this process.

    Returns
    -------
    dict
        Figure key → path written.

    Raises
    ------
    drumroll.errors.DrumrollError
        If the main model is not among the fits, ``out_dir`` is not a folder, or a figure
        file exists and ``overwrite`` is false (checked before anything is drawn).
    """
    if inputs.main not in inputs.idatas:
        raise DrumrollError(f"main model {inputs.main!r} was not fitted "
                            f"(fitted: {', '.join(inputs.idatas) or 'none'})")
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise DrumrollError(f"{out_dir}: no such directory")
    paths = {key: out_dir / name for key, name in figure_files(inputs).items()}
    for path in paths.values():
        fileio.check_writable(path, overwrite=overwrite)
    return {key: FIGURES[key].draw(inputs, path, overwrite) for key, path in paths.items()}


def load_figure_libraries() -> None:
    """Import what drawing needs (matplotlib's Agg canvas and figure, scipy's image filter),
    and render one mathtext label into memory (building the mathtext parser and loading the
    fonts), e.g. while the models are sampled, so that the figures' worker processes, forked
    afterwards, share all of it rather than each doing it again (half a second each)."""
    import io

    import scipy.ndimage  # noqa: F401  (the corner plot's smoothing)
    from matplotlib.backends import backend_agg  # noqa: F401
    from matplotlib.figure import Figure as _Figure

    from drumroll.reporting.plot_style import style

    with style():
        figure = _Figure(figsize=(1, 1))
        figure.text(0.5, 0.5, r"$\alpha$ = $\mathdefault{0.9}$")
        figure.savefig(io.BytesIO(), format="png")
