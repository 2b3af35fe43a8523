"""Writing an estimate to disk: its registered files, atomically, figures drawn side by side
(and, with a :class:`FigureDrawer` listening to the estimate, while it is still running).

An estimate's outputs are the data files of :data:`DATA_FILES` (``summary.json``,
``posterior.nc``, ``report.md``, ``report.html``) and the figures of
:data:`~drumroll.reporting.figures.FIGURES`, each registered once with its file name and
writer. Everything is first written into a hidden staging folder inside the output folder and
then renamed into place file by file, so an interrupted run (Ctrl-C included) or a disk that
fills up leaves no half-written file, and existing files are replaced only with
``overwrite``.

``posterior.nc`` is written and read by :mod:`drumroll.reporting.posterior_file`
(:func:`load_posteriors` is re-exported here).
"""

from __future__ import annotations

import contextlib
import gc
import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drumroll import fileio
from drumroll.errors import DrumrollError
from drumroll.inference.results import Diagnostics, Summary
from drumroll.interruption import raise_if_interrupted
from drumroll.onsets import ONSET_FILE_SUFFIXES
from drumroll.reporting.figures import (
    DRAW_SECONDS,
    FIGURES,
    FigureInputs,
    figure_files,
    load_figure_libraries,
)
from drumroll.reporting.plot_style import missing_glyphs_said_once
from drumroll.reporting.posterior_file import load_posteriors, save_posteriors
from drumroll.reporting.report import write_report
from drumroll.workers import process_pool

__all__ = ["DATA_FILES", "DataFile", "FigureDrawer", "check_outputs", "load_posteriors",
           "output_files", "save_posteriors", "write_outputs"]


@dataclass(frozen=True)
class DataFile:
    """One data file of an estimate: its name and its writer, called with the result, the
    path to write and the figures written (a report links or embeds them: it is written
    after the figures, ``after_figures``)."""

    key: str
    file: str
    write: Callable[[Any, Path, dict[str, Path]], Any]
    after_figures: bool = False


def _summary(result: Any, path: Path, figures: dict[str, Path]) -> Path:
    text = json.dumps(result.summary.to_json(), indent=2, ensure_ascii=False) + "\n"
    return fileio.write_text(path, text, overwrite=True)


def _posterior(result: Any, path: Path, figures: dict[str, Path]) -> None:
    save_posteriors(result.draws, result.model, path)


def _report(result: Any, path: Path, figures: dict[str, Path]) -> Path:
    return write_report(path, result.summary, figures, overwrite=True)


#: The data files, by key, in the order they are written (the reports last: they link or
#: embed the figures). ``report.html`` is the same document as ``report.md``, one page with
#: the figures embedded.
DATA_FILES: dict[str, DataFile] = {d.key: d for d in (
    DataFile("summary", "summary.json", _summary),
    DataFile("posterior", "posterior.nc", _posterior),
    DataFile("report", "report.md", _report, after_figures=True),
    DataFile("report_html", "report.html", _report, after_figures=True),
)}


def output_files(include_onsets_figure: bool = True) -> list[str]:
    """Names of every file :func:`write_outputs` may write (known before the estimate runs,
    so that existing files are refused before any work)."""
    return [*(d.file for d in DATA_FILES.values()),
            *(f.file for key, f in FIGURES.items()
              if include_onsets_figure or key != "onsets")]


def check_outputs(out_dir: str | os.PathLike[str], names: Iterable[str], *,
                  overwrite: bool = False) -> Path:
    """Fail early (before any sampling) if an output would replace a file without leave."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise DrumrollError(f"{out_dir}: exists and is not a directory")
    fileio.check_folder_writable(out_dir if out_dir.is_dir() else out_dir.parent)
    if not overwrite and out_dir.is_dir():
        existing = [name for name in names if (out_dir / name).exists()]
        if existing:
            # With --force the folder becomes this run's: each of these is replaced, or
            # removed where this run writes no such file (write_outputs' last step).
            raise DrumrollError(f"{out_dir}: would overwrite {', '.join(existing)} (use --force "
                                "to replace an earlier run's outputs there, or another --out)")
    return out_dir


def figure_inputs(result: Any, truths: dict[str, float] | None = None) -> FigureInputs:
    """What the figures of ``result`` (a :class:`drumroll.pipeline.Result`) are given."""
    audio = _audio(result.source)
    fit = result.fits.get(result.summary.model)
    return FigureInputs(idatas=result.draws, summary=result.summary,
                        truths=_truths_as_sampled(fit.log_posterior if fit else None, truths),
                        audio=audio, onsets=result.onsets if audio is not None else None)


def _audio(source: Any) -> Any:
    """The recording of an estimate's source (None when the onsets came from a file)."""
    return source if source is not None and source.suffix.lower() not in ONSET_FILE_SUFFIXES \
        else None


def _truths_as_sampled(log_posterior: Any, truths: dict[str, float] | None
                       ) -> dict[str, float] | None:
    """``truths`` in the quantities the figures draw of the main model (``log_posterior``): a
    true jitter is the noise's sd, which under Student-t noise with a fixed ν is the sampled
    scale σ times √(ν / (ν − 2)); with ν sampled there is no one scale to mark, so none is
    drawn."""
    if not truths or log_posterior is None or log_posterior.noise != "student-t" \
            or "jitter_ms" not in truths:
        return truths
    nu = log_posterior.space.priors["nu"]
    out = dict(truths)
    if nu.is_fixed and nu.value > 2:
        out["jitter_ms"] = truths["jitter_ms"] * math.sqrt((nu.value - 2) / nu.value)
    else:
        del out["jitter_ms"]
    return out


def _draw_figure(key: str, inputs: FigureInputs, path: Path) -> Path:
    """Draw figure ``key`` into ``path`` with the cyclic garbage collector paused.

    A figure is tens of thousands of small objects (artists, transforms, texts) that live
    until it is saved: every collection while it is built traverses them again without
    freeing anything (a quarter of the corner plot's time went to collections). What is
    cyclic garbage is collected afterwards, once, when the collector is re-enabled.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        with missing_glyphs_said_once(path.name):
            return FIGURES[key].draw(inputs, path, True)
    finally:
        if enabled:
            gc.enable()


class FigureDrawer:
    """Draws an estimate's figures in worker processes as soon as each one's inputs exist.

    Given to :func:`drumroll.pipeline.estimate` as its listener
    (:class:`~drumroll.pipeline.EstimateListener`'s hooks), it starts the recording's
    ``onsets.png`` while the models are being sampled, and ``corner.png`` and ``trace.png``
    once the main model's fit is back, while the other models are still sampled; given to
    :func:`write_outputs`, it draws the rest in the same workers, and ``write_outputs`` moves
    them all into place. Cores that would wait (for the last model, for the comparison) draw
    instead. The figures are drawn into a staging folder inside the output folder, as
    ``write_outputs`` draws them; use it as a context manager: on leaving it the workers end
    (at once, on an exception) and whatever ``write_outputs`` has not taken over is removed.
    With one worker it does nothing, and ``write_outputs`` draws every figure at the end.

    Parameters
    ----------
    out_dir
        The output folder (checked beforehand: :func:`check_outputs`).
    truths
        Known values for the corner plot (simulations).
    workers
        Figure processes (default: one per core).
    """

    def __init__(self, out_dir: str | os.PathLike[str], *,
                 truths: dict[str, float] | None = None, workers: int | None = None) -> None:
        self.out_dir = Path(out_dir)
        self.truths = truths
        self.workers = max(1, workers or os.cpu_count() or 1)
        #: Figure key → the drawing under way (its result is the path drawn).
        self.futures: dict[str, Future] = {}
        self.staging: Path | None = None
        self.created = False
        #: Set by write_outputs once the outputs are in place.
        self.finished = False
        self.pool: Any = None
        self._stack = contextlib.ExitStack()

    def __enter__(self) -> FigureDrawer:
        return self

    def __exit__(self, *exc: Any) -> None:
        try:
            self._stack.__exit__(*exc)
        finally:
            # After the workers ended: none of them writes into the staging folder any more.
            if self.staging is not None and not self.finished:
                shutil.rmtree(self.staging, ignore_errors=True)
                if self.created:
                    with contextlib.suppress(OSError):
                        self.out_dir.rmdir()

    def _submit(self, key: str, inputs: FigureInputs) -> None:
        if self.workers < 2:
            return
        if self.pool is None:
            load_figure_libraries()  # before the workers fork: they share it
            self.created = not self.out_dir.exists()
            try:
                self.out_dir.mkdir(exist_ok=True)
                self.staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=self.out_dir))
            except OSError as exc:
                if fileio.no_space(exc):
                    raise fileio.no_space_error(self.out_dir, exc) from None
                raise
            self.pool = self._stack.enter_context(process_pool(self.workers))
        previous = self.futures.get(key)
        if previous is not None and not previous.cancel():
            # Drawn again (the estimate fitted again with another numbering): the earlier
            # drawing ends before this one starts, so it cannot overwrite it.
            previous.exception()
        self.futures[key] = self.pool.submit(_draw_figure, key, inputs,
                                             self.staging / FIGURES[key].file)

    def sampling(self, onsets: Any, recording: Any) -> None:
        """The estimate's hook while the models are sampled: draw the recording's onsets."""
        audio = _audio(recording)
        if audio is not None:
            self._submit("onsets", FigureInputs(idatas={}, summary=Summary(), audio=audio,
                                                onsets=onsets))
        elif self.workers > 1:
            load_figure_libraries()  # for the figures to come, while this process waits

    def main_fit(self, fit: Any) -> None:
        """The estimate's hook for the main model's fit (a :class:`~drumroll.pipeline.MainFit`):
        draw its corner and trace plots."""
        summary = Summary(model=fit.model, parameters=fit.parameters,
                          diagnostics={fit.model: Diagnostics(max_r_hat=fit.max_r_hat)})
        inputs = FigureInputs(idatas={fit.model: fit.draws}, summary=summary,
                              truths=_truths_as_sampled(fit.log_posterior, self.truths))
        for key in ("corner", "trace"):
            self._submit(key, inputs)


def write_outputs(result: Any, out_dir: str | os.PathLike[str], *, overwrite: bool = False,
                  truths: dict[str, float] | None = None, workers: int | None = None,
                  drawer: FigureDrawer | None = None) -> dict[str, Path]:
    """Write every output of ``result`` (a :class:`drumroll.pipeline.Result`) into ``out_dir``.

    The figures are drawn by ``workers`` processes (default: one per core) while this one
    writes ``summary.json`` and ``posterior.nc``; with a ``drawer`` that listened to the
    estimate, by its workers, and those it already drew or is drawing are not drawn again.

    Returns
    -------
    dict
        Output key (:data:`DATA_FILES`, :data:`~drumroll.reporting.figures.FIGURES`) → final
        path.
    """
    inputs = figure_inputs(result, truths)
    figures = figure_files(inputs)
    names = [*(d.file for d in DATA_FILES.values()), *figures.values()]
    out_dir = check_outputs(out_dir, names, overwrite=overwrite)
    early = drawer is not None and drawer.staging is not None
    created = drawer.created if early else not out_dir.exists()
    staging: Path | None = drawer.staging if early else None
    finished = False
    try:
        if not early:
            try:
                out_dir.mkdir(exist_ok=True)
                staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=out_dir))
            except OSError as exc:
                if fileio.no_space(exc):
                    raise fileio.no_space_error(out_dir, exc) from None
                raise
        written = _write_staged(result, inputs, figures, staging, out_dir, overwrite=overwrite,
                                workers=workers, drawer=drawer if early else None)
        finished = True
        if early:
            drawer.finished = True
        return written
    except fileio.NoSpace as exc:  # named by its final path, not the staging folder's
        if staging is None:
            raise
        raise exc.moved(staging, out_dir) from None
    finally:
        # On a failure with a drawer, the drawer cleans up once its workers have ended.
        with contextlib.suppress(OSError):
            if finished or not early:
                if staging is not None:
                    shutil.rmtree(staging)
                if created and not finished:
                    out_dir.rmdir()  # only if still empty: a folder we made and left empty


def _write_data(data: DataFile, result: Any, path: Path, figures: dict[str, Path]) -> None:
    """Write ``data`` to ``path``; for want of room, the error names ``path``."""
    try:
        data.write(result, path, figures)
    except OSError as exc:
        if not fileio.no_space(exc):
            raise
        raise fileio.no_space_error(path, exc) from None


def _write_staged(result: Any, inputs: FigureInputs, figures: dict[str, str], staging: Path,
                  out_dir: Path, *, overwrite: bool, workers: int | None,
                  drawer: FigureDrawer | None = None) -> dict[str, Path]:
    """Write every output into ``staging``, then move each into ``out_dir`` (the figures a
    ``drawer`` drew or is drawing there are taken as they are).

    Raises
    ------
    drumroll.fileio.NoSpace
        An output found no room on the disk (named by its path in ``staging``).
    """
    order = sorted(figures, key=lambda key: -DRAW_SECONDS.get(key, 1.0))  # slowest first
    workers = max(1, min(workers or os.cpu_count() or 1, len(order)))
    drawn: dict[str, Path] = {}
    with contextlib.ExitStack() as stack:
        if drawer is not None:
            pool, futures = drawer.pool, dict(drawer.futures)
        else:
            pool = stack.enter_context(process_pool(workers)) if workers > 1 else None
            futures = {}
        if pool is not None:
            futures.update({key: pool.submit(_draw_figure, key, inputs, staging / figures[key])
                            for key in order if key not in futures})
        for data in DATA_FILES.values():
            if not data.after_figures:
                _write_data(data, result, staging / data.file, {})
        for key in order:
            drawn[key] = (futures[key].result() if pool is not None
                          else _draw_figure(key, inputs, staging / figures[key]))
    for data in DATA_FILES.values():
        if data.after_figures:
            _write_data(data, result, staging / data.file, {k: drawn[k] for k in figures})
    written = {}
    # The commit point: a Ctrl-C or SIGTERM whose exception was swallowed (raised in a
    # garbage collector's callback) must not let the outputs through.
    raise_if_interrupted()
    keys = {d.file: k for k, d in DATA_FILES.items()} | {v: k for k, v in figures.items()}
    for path in sorted(staging.iterdir()):
        final = out_dir / path.name
        if final.exists() and not overwrite:
            raise DrumrollError(f"{final}: appeared while we were working; not replaced")
        os.replace(path, final)
        written[keys.get(path.name, path.stem)] = final
    if overwrite:
        # The folder is this run's now: a figure of the run it replaces that this one
        # does not draw (onsets.png of a recording, when these onsets came from a file;
        # comparison.png of a run that compared models) would sit beside results it does
        # not belong to. Only our own names are touched.
        for name in set(output_files()) - {p.name for p in written.values()}:
            with contextlib.suppress(FileNotFoundError):
                (out_dir / name).unlink()
    return written
