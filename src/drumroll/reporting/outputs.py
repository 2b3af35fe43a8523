"""Writing an estimate to disk: ``summary.json``, ``posterior.nc``, ``report.md`` and figures.

Everything is first written into a hidden staging folder inside the output folder and then
renamed into place file by file, so an interrupted run (Ctrl-C included) leaves no
half-written file, and existing files are replaced only with ``overwrite``.

``posterior.nc`` is written and read by :mod:`drumroll.reporting.posterior_file`
(:func:`load_posteriors` is re-exported here).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from drumroll import fileio
from drumroll.errors import DrumrollError
from drumroll.reporting.figures import FIGURE_FILES, figure_jobs
from drumroll.reporting.onset_plot import write_onset_plot
from drumroll.reporting.posterior_file import load_posteriors, save_posteriors
from drumroll.reporting.report import write_report
from drumroll.workers import process_pool

#: Files an estimate writes, besides the figures.
__all__ = ["DATA_FILES", "check_outputs", "load_posteriors", "output_files",
           "save_posteriors", "write_outputs"]

DATA_FILES = ("summary.json", "posterior.nc", "report.md")
ONSETS_FIGURE = "onsets.png"


def output_files(include_onsets_figure: bool = True) -> list[str]:
    """Names of every file :func:`write_outputs` writes."""
    names = [*DATA_FILES, *FIGURE_FILES.values()]
    return [*names, ONSETS_FIGURE] if include_onsets_figure else names


def check_outputs(out_dir: str | os.PathLike[str], names: Iterable[str], *,
                  overwrite: bool = False) -> Path:
    """Fail early (before any sampling) if an output would replace a file without leave."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise DrumrollError(f"{out_dir}: exists and is not a directory")
    if not out_dir.parent.exists():
        raise DrumrollError(f"{out_dir.parent}: no such directory")
    if not overwrite and out_dir.is_dir():
        existing = [name for name in names if (out_dir / name).exists()]
        if existing:
            raise DrumrollError(f"{out_dir}: would overwrite {', '.join(existing)} (use --force "
                                "or another --out)")
    return out_dir


def _json_safe(value: Any) -> Any:
    """Replace NaN and infinities by None so the file is valid JSON."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    return value


def write_outputs(result: Any, out_dir: str | os.PathLike[str], *, overwrite: bool = False,
                  truths: dict[str, float] | None = None, workers: int | None = None
                  ) -> dict[str, Path]:
    """Write every output of ``result`` (a :class:`drumroll.pipeline.Result`) into ``out_dir``.

    The figures are drawn by ``workers`` processes (default: one per core) while this one
    writes ``posterior.nc`` and ``summary.json``.

    Returns
    -------
    dict
        Output name → final path.
    """
    audio = result.source if result.source is not None and result.source.suffix.lower() \
        not in fileio.ONSET_FILE_SUFFIXES else None
    names = output_files(include_onsets_figure=audio is not None)
    out_dir = check_outputs(out_dir, names, overwrite=overwrite)
    created = not out_dir.exists()
    out_dir.mkdir(exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=out_dir))
    finished = False
    try:
        jobs = figure_jobs(result.idatas, result.model,
                           {key: staging / name for key, name in FIGURE_FILES.items()},
                           comparison=result.summary["comparison"], truths=truths,
                           overwrite=True, loos=result.loos)
        if audio is not None:
            jobs["onsets"] = (write_onset_plot, (staging / ONSETS_FIGURE, audio, result.onsets),
                              {"overwrite": True})
        workers = max(1, min(workers or os.cpu_count() or 1, len(jobs)))
        with contextlib.ExitStack() as stack:
            pool = (stack.enter_context(process_pool(workers))
                    if workers > 1 else None)
            futures = {key: pool.submit(function, *args, **kwargs) for key, (function, args,
                       kwargs) in jobs.items()} if pool is not None else {}
            summary = _json_safe(result.summary)
            fileio.write_text(staging / "summary.json", json.dumps(summary, indent=2) + "\n",
                              overwrite=True)
            save_posteriors(result.idatas, result.model, staging / "posterior.nc")
            figures = ({key: future.result() for key, future in futures.items()}
                       if pool is not None else
                       {key: function(*args, **kwargs)
                        for key, (function, args, kwargs) in jobs.items()})
        write_report(staging / "report.md", summary, figures, overwrite=True)
        written = {}
        for path in sorted(staging.iterdir()):
            final = out_dir / path.name
            if final.exists() and not overwrite:
                raise DrumrollError(f"{final}: appeared while we were working; not replaced")
            os.replace(path, final)
            written[path.stem] = final
        finished = True
        return written
    finally:
        with contextlib.suppress(OSError):
            shutil.rmtree(staging)
            if created and not finished:
                out_dir.rmdir()  # only if still empty: a folder we made and filled with nothing
