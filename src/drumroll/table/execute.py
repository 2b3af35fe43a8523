"""Running the runs of a table side by side, with results cached by content.

Each run is one :func:`drumroll.pipeline.estimate` (main model and its comparison) plus the
prior propagation of :func:`~drumroll.inference.prior_predictive.propagate` (the paper's
"computed t_B"). Runs go to a :class:`concurrent.futures.Executor` (processes, or a Dask
cluster's executor); each finished run is written at once, atomically, to
``<cache>/<key>.json``, where the key hashes the source file's bytes, the effective config,
the drumroll version and its code. An unchanged table is then read back without sampling, a
new run is the only one computed, and an interrupted table resumes where it stopped.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import time
import warnings
from collections.abc import Callable
from concurrent.futures import Executor, Future, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from drumroll import fileio
from drumroll._version import __version__
from drumroll.errors import DrumrollError, DrumrollWarning
from drumroll.inference.results import ParameterSummary, Record, Summary
from drumroll.progress import ProgressLike, as_progress
from drumroll.table.runs import Run, RunsFile, validate_estimation
from drumroll.workers import process_pool

#: Bumped whenever the cached row's layout changes (old entries are then recomputed).
CACHE_SCHEMA = 4
#: Monte Carlo draws of the computed t_B (the sd's relative precision is ~0.5 %).
PREDICT_DRAWS = 20_000
#: Seed of the computed t_B's draws.
PREDICT_SEED = 0


@dataclass(frozen=True)
class Estimate(Record):
    """A value with its error (None when not known): a posterior mean ± sd, or a prior
    propagation's mean ± sd."""

    value: float | None = None
    err: float | None = None

    @classmethod
    def of(cls, stats: ParameterSummary | None) -> Estimate:
        """The mean ± sd of a posterior summary (None: both None)."""
        return cls() if stats is None else cls(stats.mean, stats.sd)


@dataclass(frozen=True)
class RunRow(Record):
    """One run of a table, as cached: the estimate's summary and the prior propagation.

    Attributes
    ----------
    summary
        The run's :class:`~drumroll.inference.results.Summary`.
    computed_t_b
        Model → t_B propagated from the priors (the paper's "computed t_B").
    seconds
        Wall time of the run.
    """

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "summary": (Summary, "one"), "computed_t_b": (Estimate, "dict")}

    schema: int = CACHE_SCHEMA
    version: str = ""
    summary: Summary = field(default_factory=Summary)
    computed_t_b: dict[str, Estimate] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def alpha(self) -> Estimate:
        """The main model's α (posterior mean ± sd)."""
        return Estimate.of(self.summary.parameters.get("alpha"))

    @property
    def alpha_averaged(self) -> Estimate:
        """α of the fitted models averaged by stacking (the main model's alone when it was
        the only one fitted)."""
        average = self.summary.model_average
        if average is None or "alpha" not in average.parameters:
            return self.alpha
        return Estimate.of(average.parameters["alpha"])

    @property
    def fitted_t_b(self) -> Estimate:
        """The main model's t_B (posterior mean ± sd)."""
        return Estimate.of(self.summary.parameters.get("t_b"))


@dataclass
class TableResult:
    """What ``drumroll table`` computed.

    Attributes
    ----------
    runs
        The parsed RUNS file.
    rows
        Per run (same order), the cached/computed row data (see :func:`compute_run`).
    computed
        Labels of the runs sampled in this call (the others came from the cache).
    joint
        The joint fit's summary when ``share`` is set (see :mod:`drumroll.table.joint`).
    seconds
        Wall time of the whole call.
    """

    runs: RunsFile
    rows: list[RunRow]
    computed: list[str] = field(default_factory=list)
    joint: dict[str, Any] | None = None
    seconds: float = 0.0

    def __repr__(self) -> str:
        title = f" {self.runs.title!r}" if self.runs.title else f" of {self.runs.path.name}"
        labels = ", ".join(run.label for run in self.runs.runs)
        return (f"<drumroll table{title}: {len(self.rows)} runs ({labels}), "
                f"{len(self.computed)} computed, {len(self.rows) - len(self.computed)} from "
                "the cache>")

    # The rich displays of a notebook: the table and its Figure 5.
    def _repr_html_(self) -> str:
        from drumroll.reporting.display import table_display, to_html

        return to_html(table_display(self))

    def _repr_markdown_(self) -> str:
        from drumroll.table.formatting import to_markdown

        return to_markdown(self)


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (read in 1 MiB blocks)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@functools.cache
def code_digest() -> str:
    """SHA-256 of the drumroll package's Python sources.

    The version alone does not change while the package is developed (an editable install):
    with this in the key, any edit of the code invalidates the cache (a few ms to compute).
    """
    digest = hashlib.sha256()
    package = Path(__file__).resolve().parents[1]
    for path in sorted(package.rglob("*.py")):
        digest.update(str(path.relative_to(package)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def run_key(run: Run) -> str:
    """The cache key of a run: its source's bytes, the roll fitted and the audio stream read,
    the effective config, the drumroll version and its code (:func:`code_digest`)."""
    document = {"source_sha256": file_digest(run.source), "config": run.raw,
                "version": __version__, "code": code_digest(), "schema": CACHE_SCHEMA,
                "predict": [PREDICT_DRAWS, PREDICT_SEED]}
    if run.roll is not None:  # (absent otherwise, so that the keys of other runs stay put)
        document["roll"] = run.roll
    if run.stream is not None:  # (likewise)
        document["stream"] = run.stream
    text = json.dumps(document, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:40]


def compute_run(source: str, raw: dict[str, Any], roll: int | None = None,
                stream: int | None = None) -> RunRow:
    """Estimate one run (roll ``roll`` of its source, default the longest; audio stream
    ``stream``, default the first) and propagate its priors.

    Runs in a worker (a process or a Dask worker): it takes only picklable, plain inputs and
    imports the heavy modules itself.
    """
    from drumroll.config import parse_config
    from drumroll.inference.prior_predictive import propagate
    from drumroll.physics import GEOMETRIC_MODELS
    from drumroll.pipeline import estimate

    started = time.perf_counter()
    config = parse_config(raw)
    # No bar of its own: the table's bar counts the runs.
    result = estimate(source, config, roll=roll, progress=False,
                      **({} if stream is None else {"stream": stream}))
    computed: dict[str, Estimate] = {}
    if config.stick is not None:
        for model in GEOMETRIC_MODELS:
            prediction = propagate(config, model, n_flights=1, n_draws=PREDICT_DRAWS,
                                   seed=PREDICT_SEED).summary()["t_b"]
            computed[model] = Estimate(prediction["mean"], prediction["sd"])
    return RunRow(version=__version__, summary=result.summary, computed_t_b=computed,
                  seconds=time.perf_counter() - started)


def read_json(path: Path) -> dict[str, Any] | None:
    """A cache entry's JSON, or None when absent, unreadable or of another schema."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("schema") == CACHE_SCHEMA else None


def read_cached(path: Path) -> RunRow | None:
    """A cached row, or None when absent, unreadable, damaged or of another schema."""
    data = read_json(path)
    if data is None:
        return None
    try:
        return RunRow.from_json(data)
    except (TypeError, ValueError, KeyError, AttributeError):
        return None  # a damaged entry is recomputed


def write_cached(folder: Path, key: str, entry: RunRow | dict[str, Any]) -> None:
    """Write a cache entry (a row, or a joint fit's JSON) atomically.

    A cache that cannot be written (no room on the disk, a folder gone read-only or
    replaced by a file since the command checked it) is a warning, the same line for every
    entry (shown once): the table is complete without it, only the next run computes it
    again.
    """
    data = entry.to_json() if isinstance(entry, Record) else entry
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fileio.write_text(folder / f"{key}.json",
                          json.dumps(data, indent=1, ensure_ascii=False), overwrite=True)
    except fileio.NoSpace as exc:
        reason = exc.reason
    except DrumrollError as exc:  # the entry's file cannot be made there
        reason = str(exc).removeprefix(f"{folder / key}.json: ")
    except OSError as exc:
        reason = (fileio.NO_SPACE[exc.errno][0] if fileio.no_space(exc)
                  else exc.strerror or str(exc))
    else:
        return
    warnings.warn(f"{folder}: the cache is not written ({reason}); the next run computes "
                  "these runs again", DrumrollWarning, stacklevel=2)


def default_workers() -> int:
    """Processes to use by default: the machine's cores."""
    return os.cpu_count() or 1


def run_table(runs: RunsFile, *, workers: int | None = None, executor: Executor | None = None,
              cache_dir: Path | None = None, use_cache: bool = True,
              progress: ProgressLike = None) -> TableResult:
    """Every run's row, from the cache or computed in parallel.

    Parameters
    ----------
    runs
        The parsed RUNS file.
    workers
        Processes when no ``executor`` is given (default: the cores; 1 runs in this process).
    executor
        Any :class:`concurrent.futures.Executor` (e.g. a Dask client's ``get_executor()``);
        the caller owns it.
    cache_dir
        Cache folder (default: ``.drumroll-cache/`` beside the RUNS file).
    use_cache
        Read and write the cache (False: compute everything, write nothing).
    progress
        Where the table reports (:func:`drumroll.progress.as_progress`): None shows a bar of
        the runs done, with the time left, where a person watches (a terminal, a notebook)
        and nothing elsewhere; False nothing; a callable is called with a line of news per
        finished run; or a :class:`~drumroll.progress.Progress`.

    Raises
    ------
    DrumrollError
        A run failed (one line naming it); the runs finished before stay cached.
    """
    reporter = as_progress(progress)
    say = reporter.say
    started = time.perf_counter()
    folder = cache_dir if cache_dir is not None else runs.cache_dir
    keys = [run_key(run) for run in runs.runs]
    rows: list[RunRow | None] = [None] * len(runs.runs)
    if use_cache:
        for i, key in enumerate(keys):
            rows[i] = read_cached(folder / f"{key}.json")
    todo = [i for i, row in enumerate(rows) if row is None]
    for i in todo:  # every config fully valid before anything is sampled
        try:
            validate_estimation(runs.runs[i])
        except DrumrollError as exc:  # named as the runs file's other errors are
            raise type(exc)(f"{runs.path}: {exc}") from None
    if len(todo) < len(rows):
        say(f"{len(rows) - len(todo)} of {len(rows)} runs from the cache ({folder})")

    def finish(i: int, row: RunRow) -> None:
        rows[i] = row
        if use_cache:
            write_cached(folder, keys[i], row)
        done = sum(r is not None for r in rows)
        say(f"run {runs.runs[i].label!r}: done in {row.seconds:.1f} s ({done}/{len(rows)})")
        bar.advance(note=runs.runs[i].label)

    errors: list[DrumrollError] = []

    def fail(i: int, exc: DrumrollError) -> None:
        errors.append(DrumrollError(f"run {runs.runs[i].label!r}: {exc}"))
        say(f"run {runs.runs[i].label!r} failed: {exc}")
        bar.advance(note=f"{runs.runs[i].label} failed")

    with reporter.bar(len(rows), "table", "run", initial=len(rows) - len(todo)) as bar:
        if todo:
            n = max(1, min(workers or default_workers(), len(todo)))
            say(f"estimating {len(todo)} run{'s' if len(todo) > 1 else ''} "
                + (f"on {type(executor).__name__}" if executor is not None else
                   f"in {n} process{'es' if n > 1 else ''}"))
            if executor is None and n == 1:
                for i in todo:
                    try:
                        row = compute_run(str(runs.runs[i].source), runs.runs[i].raw,
                                          runs.runs[i].roll, runs.runs[i].stream)
                    except DrumrollError as exc:
                        fail(i, exc)
                        continue
                    finish(i, row)
            elif executor is not None:
                _submit_all(executor, runs, todo, finish, fail)
            else:
                with process_pool(n) as pool:
                    _submit_all(pool, runs, todo, finish, fail)
    if errors:  # the runs that succeeded are cached: fix the failing one and re-run
        raise errors[0]
    return TableResult(runs=runs, rows=[r for r in rows if r is not None],
                       computed=[runs.runs[i].label for i in todo],
                       seconds=time.perf_counter() - started)


def _submit_all(executor: Executor, runs: RunsFile, todo: list[int],
                finish: Callable[[int, RunRow], None],
                fail: Callable[[int, DrumrollError], None]) -> None:
    """Submit the runs in ``todo``; hand each result to ``finish`` (or its user error to
    ``fail``) as it completes. Anything else, Ctrl-C included, cancels the runs not started."""
    futures: dict[Future, int] = {
        executor.submit(compute_run, str(runs.runs[i].source), runs.runs[i].raw,
                        runs.runs[i].roll, runs.runs[i].stream): i
        for i in todo}
    try:
        for future in as_completed(futures):
            i = futures[future]
            try:
                row = future.result()
            except DrumrollError as exc:
                fail(i, exc)
                continue
            finish(i, row)
    except BaseException:
        for future in futures:
            future.cancel()
        raise
