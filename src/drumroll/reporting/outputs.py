"""Writing an estimate to disk: its registered files, atomically, figures drawn side by side.

An estimate's outputs are the data files of :data:`DATA_FILES` (``summary.json``,
``posterior.nc``, ``report.md``) and the figures of
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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drumroll import fileio
from drumroll.errors import DrumrollError
from drumroll.interruption import raise_if_interrupted
from drumroll.onsets import ONSET_FILE_SUFFIXES
from drumroll.reporting.figures import DRAW_SECONDS, FIGURES, FigureInputs, figure_files
from drumroll.reporting.plot_style import missing_glyphs_said_once
from drumroll.reporting.posterior_file import load_posteriors, save_posteriors
from drumroll.reporting.report import write_report
from drumroll.workers import process_pool

__all__ = ["DATA_FILES", "DataFile", "check_outputs", "load_posteriors", "output_files",
           "save_posteriors", "write_outputs"]


@dataclass(frozen=True)
class DataFile:
    """One data file of an estimate: its name and its writer, called with the result, the
    path to write and the figures written (the report links them)."""

    key: str
    file: str
    write: Callable[[Any, Path, dict[str, Path]], Any]


def _summary(result: Any, path: Path, figures: dict[str, Path]) -> Path:
    text = json.dumps(result.summary.to_json(), indent=2, ensure_ascii=False) + "\n"
    return fileio.write_text(path, text, overwrite=True)


def _posterior(result: Any, path: Path, figures: dict[str, Path]) -> None:
    save_posteriors(result.draws, result.model, path)


def _report(result: Any, path: Path, figures: dict[str, Path]) -> Path:
    return write_report(path, result.summary, figures, overwrite=True)


#: The data files, by key, in the order they are written (the report last: it links the
#: figures).
DATA_FILES: dict[str, DataFile] = {d.key: d for d in (
    DataFile("summary", "summary.json", _summary),
    DataFile("posterior", "posterior.nc", _posterior),
    DataFile("report", "report.md", _report),
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
            raise DrumrollError(f"{out_dir}: would overwrite {', '.join(existing)} (use --force "
                                "or another --out)")
    return out_dir


def figure_inputs(result: Any, truths: dict[str, float] | None = None) -> FigureInputs:
    """What the figures of ``result`` (a :class:`drumroll.pipeline.Result`) are given."""
    audio = result.source if result.source is not None and result.source.suffix.lower() \
        not in ONSET_FILE_SUFFIXES else None
    return FigureInputs(idatas=result.draws, summary=result.summary,
                        truths=_truths_as_sampled(result, truths), audio=audio,
                        onsets=result.onsets if audio is not None else None)


def _truths_as_sampled(result: Any, truths: dict[str, float] | None) -> dict[str, float] | None:
    """``truths`` in the quantities the figures draw: a true jitter is the noise's sd, which
    under Student-t noise with a fixed ν is the sampled scale σ times √(ν / (ν − 2)); with ν
    sampled there is no one scale to mark, so none is drawn."""
    fit = result.fits.get(result.summary.model) if truths else None
    if fit is None or fit.log_posterior.noise != "student-t" or "jitter_ms" not in truths:
        return truths
    nu = fit.log_posterior.space.priors["nu"]
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


def write_outputs(result: Any, out_dir: str | os.PathLike[str], *, overwrite: bool = False,
                  truths: dict[str, float] | None = None, workers: int | None = None
                  ) -> dict[str, Path]:
    """Write every output of ``result`` (a :class:`drumroll.pipeline.Result`) into ``out_dir``.

    The figures are drawn by ``workers`` processes (default: one per core) while this one
    writes ``summary.json`` and ``posterior.nc``.

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
    created = not out_dir.exists()
    staging: Path | None = None
    finished = False
    try:
        try:
            out_dir.mkdir(exist_ok=True)
            staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=out_dir))
        except OSError as exc:
            if fileio.no_space(exc):
                raise fileio.no_space_error(out_dir, exc) from None
            raise
        written = _write_staged(result, inputs, figures, staging, out_dir, overwrite=overwrite,
                                workers=workers)
        finished = True
        return written
    except fileio.NoSpace as exc:  # named by its final path, not the staging folder's
        if staging is None:
            raise
        raise exc.moved(staging, out_dir) from None
    finally:
        with contextlib.suppress(OSError):
            if staging is not None:
                shutil.rmtree(staging)
            if created and not finished:
                out_dir.rmdir()  # only if still empty: a folder we made and filled with nothing


def _write_data(data: DataFile, result: Any, path: Path, figures: dict[str, Path]) -> None:
    """Write ``data`` to ``path``; for want of room, the error names ``path``."""
    try:
        data.write(result, path, figures)
    except OSError as exc:
        if not fileio.no_space(exc):
            raise
        raise fileio.no_space_error(path, exc) from None


def _write_staged(result: Any, inputs: FigureInputs, figures: dict[str, str], staging: Path,
                  out_dir: Path, *, overwrite: bool, workers: int | None) -> dict[str, Path]:
    """Write every output into ``staging``, then move each into ``out_dir``.

    Raises
    ------
    drumroll.fileio.NoSpace
        An output found no room on the disk (named by its path in ``staging``).
    """
    order = sorted(figures, key=lambda key: -DRAW_SECONDS.get(key, 1.0))  # slowest first
    workers = max(1, min(workers or os.cpu_count() or 1, len(order)))
    drawn: dict[str, Path] = {}
    with contextlib.ExitStack() as stack:
        pool = stack.enter_context(process_pool(workers)) if workers > 1 else None
        futures = {key: pool.submit(_draw_figure, key, inputs, staging / figures[key])
                   for key in order} if pool is not None else {}
        for data in list(DATA_FILES.values())[:-1]:
            _write_data(data, result, staging / data.file, {})
        for key in order:
            drawn[key] = (futures[key].result() if pool is not None
                          else _draw_figure(key, inputs, staging / figures[key]))
    report = DATA_FILES["report"]
    _write_data(report, result, staging / report.file, {k: drawn[k] for k in figures})
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
