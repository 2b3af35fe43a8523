"""``drumroll.calibrate``: simulation-based calibration of ``estimate`` on a config's model.

For each of n simulations (Talts et al. 2018, arXiv:1804.06788, Algorithm 2): a parameter
point θ̃ drawn from the config's priors and a roll of onsets simulated through the main
model and its noise (:mod:`.roll`); the onsets fitted by :func:`drumroll.pipeline.estimate`
with the config's own sampler settings (walkers, ESS and R-hat targets, step limit, noise
model: exactly what ``estimate`` runs); and, per quantity, the rank of the truth among L
nearly independent posterior draws, whether the central 50 % and 90 % intervals hold it, the
z-score of the posterior mean and the posterior's contraction. With ``audio`` each roll is
also rendered as a recording, its onsets found by the extractor and fitted the same way
(:mod:`.recording`), so that the two calibrations differ by the extractor alone. The
statistics over the simulations are :mod:`drumroll.inference.calibration`'s.

Two settings of the fit differ from ``estimate``'s: the models of ``compare`` are not fitted
(they serve the comparison only), and the fit runs in one process (the simulations run side
by side instead). The simulated onsets are fitted without evidences: their numbering is
right by construction. A recording's onsets are fitted with the main model's evidences, as
``estimate`` fits them: the first onset's numbering is weighed (a first impact the
extractor missed, a tap before the roll it took for one), and a roll that is likelier
numbered otherwise is fitted again so.
Each simulation has its own seeds, derived from ``seed`` and its number alone, so
the result does not depend on the number of workers or on the order they finish in.
"""

from __future__ import annotations

import math
import os
import platform
import re
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import Executor, Future, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from drumroll._version import __version__
from drumroll.calibration.recording import EXTRACTOR_SECONDS, Recorder, TooSlow
from drumroll.calibration.results import (
    DEFAULT_ONSETS,
    RANK_DRAWS,
    CalibrationResult,
    CalibrationSettings,
    DrawRecord,
    FitRecord,
    LevelCalibration,
)
from drumroll.calibration.roll import MAX_ATTEMPTS, RollSimulator, SimulatedRoll
from drumroll.config import Config, load_config, parse_config
from drumroll.errors import AudioError, DrumrollError
from drumroll.inference.calibration import (
    calibrate_quantity,
    central_interval_covers,
    draw_spacing,
    independent_draws,
    rank_statistic,
)
from drumroll.inference.likelihood import T0_WINDOW_S, OnsetData
from drumroll.progress import ProgressLike, as_progress
from drumroll.quantities import BY_NAME, report_order
from drumroll.workers import process_pool

#: Most simulations and onsets per roll a run may ask for.
MAX_SIMULATIONS = 10_000
MAX_ONSETS = 400
#: Fewest onsets a fit can take (:data:`drumroll.pipeline.MIN_ONSETS`).
MIN_ONSETS = 4
#: Prior draws that give each quantity's prior variance (contraction's reference).
PRIOR_DRAWS = 20_000

TOO_FEW_HEARD = "the extractor found fewer than 4 onsets"
EXTRACTOR_TOO_SLOW = (f"the extractor took more than {EXTRACTOR_SECONDS:g} s on the "
                      "recording")


def fit_config(config: Config, seed: int, numbering: bool = False) -> Config:
    """The config a simulation is fitted with: the same model, priors, noise and sampler
    settings, without the compared models, in one process, with the simulation's own sampler
    ``seed``; without the evidence (it serves the comparison, not the main posterior) unless
    ``numbering``: a recording's onsets are fitted as ``estimate`` fits them, the first
    onset's numbering weighed by the main model's evidences (a missed first impact, a tap
    taken for one: :mod:`~drumroll.inference.missed_impacts`), since which numbering the
    numbers come from is part of the answer."""
    raw = dict(config.raw)
    raw["compare"] = []
    sampler = {**raw.get("sampler", {}), "workers": 1, "seed": seed}
    if not numbering:
        sampler["evidence"] = False
    raw["sampler"] = sampler
    return parse_config(raw, path=config.path)


def draw_seeds(seed: int, index: int) -> tuple[np.random.Generator, np.random.Generator,
                                                np.random.Generator, int]:
    """Simulation ``index``'s generators (the roll, the recording's sound, the choice of the
    ranked draws) and its fits' sampler seed: from ``seed`` and ``index`` alone."""
    sequence = np.random.SeedSequence([seed, index])
    roll, sound, choice, fit = sequence.spawn(4)
    return (np.random.default_rng(roll), np.random.default_rng(sound),
            np.random.default_rng(choice), int(fit.generate_state(1)[0]))


def _onset_table(times: np.ndarray):
    """The simulated onsets as ``estimate`` takes them: one roll, every bounce heard, no
    extractor uncertainty."""
    from drumroll.onsets import OnsetTable

    nan = np.full(times.size, np.nan)
    return OnsetTable(times, nan, nan, np.zeros(times.size), source="<simulated>")


def _truths(log_posterior: Any, roll: SimulatedRoll) -> dict[str, float]:
    """The true value of every quantity the fit reports (user's units), computed from θ̃ as
    the fit computes them from its draws; T0 the simulated one."""
    from drumroll.inference.inference_data import parameter_draws

    space = log_posterior.space
    point = np.array([[roll.t0 if name == "t0" else roll.values[name] for name in space.names]])
    # T0's draw (its conditional under Gaussian noise) is replaced by the truth below.
    variables, _, _ = parameter_draws(log_posterior, point, np.random.default_rng(0))
    truth = {key: float(np.ravel(value)[0]) for key, value in variables.items()}
    truth["t0_s"] = roll.t0
    return {key: value for key, value in truth.items() if math.isfinite(value)}


def _fit_record(result: Any, truth: dict[str, float], rank_draws: int,
                rng: np.random.Generator, seconds: float) -> FitRecord:
    """Ranks, moments and coverage of every quantity of one fit (see :class:`FitRecord`)."""
    model = result.model
    fit = result.fits[model]
    posterior = fit.draws.posterior  # thinned evenly to at most MAX_DRAWS draws
    attrs = fit.draws.sample_stats.attrs
    chains, draws = posterior.sizes["chain"], posterior.sizes["draw"]
    # One autocorrelation time apart; closer only if the stored draws hold too few such.
    # Whatever its random offset, a chain holds draws // spacing candidates, so this cap
    # leaves every fit rank_draws of them (ranks among different numbers of draws are on
    # different scales; chains * draws // rank_draws could leave one short).
    spacing = min(draw_spacing(attrs["tau_steps"], attrs["thin"]),
                  max(1, draws // -(-rank_draws // chains)))
    at_chain, at_draw = independent_draws(chains, draws, spacing, rank_draws, rng)
    record: dict[str, dict[str, Any]] = {name: {} for name in (
        "rank", "mean", "sd", "covered_50", "covered_90")}
    parameters = result.summary.parameters
    for key, value in truth.items():
        if key not in posterior or key not in parameters:
            continue
        values = np.asarray(posterior[key].values, float)
        stats = parameters[key]
        record["rank"][key] = rank_statistic(value, values[at_chain, at_draw], rng)
        record["mean"][key], record["sd"][key] = stats.mean, stats.sd
        record["covered_50"][key] = central_interval_covers(value, values, 0.5, rng)
        record["covered_90"][key] = central_interval_covers(value, values, 0.9, rng)
    diagnostics = result.summary.diagnostics[model]
    ess = [v for v in (diagnostics.ess_bulk_min, diagnostics.ess_tail_min) if v is not None]
    adequacy = result.summary.models[model].adequacy
    return FitRecord(n_onsets=result.summary.n_onsets, **record, rank_draws=len(at_chain),
                     spacing=spacing, converged=diagnostics.converged,
                     r_hat_max=diagnostics.r_hat_max, ess_min=min(ess) if ess else None,
                     n_steps=diagnostics.n_steps,
                     adequate=None if adequacy is None else adequacy.adequate,
                     seconds=seconds)


def _refused(exc: DrumrollError) -> str:
    """A rejection reason from the estimate's message, its numbers and names taken out so
    that one kind of refusal counts as one reason."""
    text = re.sub(r"-?\d[\d.e+-]*", "#", str(exc))
    return f"estimate refused the onsets: {text[:160]}"


def run_draw(raw: dict[str, Any], path: str | None, index: int, options: dict[str, Any]
             ) -> DrawRecord:
    """Simulation ``index``: draw, simulate, fit (and with ``options["audio"]``, render,
    extract and fit again), and rank. Runs in a worker (a process or a Dask worker): it takes
    only plain, picklable inputs.

    A roll the pipeline cannot take (the extractor hearing fewer than 4 onsets or taking
    longer than :data:`~.recording.EXTRACTOR_SECONDS`, the estimate refusing the onsets) is
    drawn again with its parameter point: a selection on the data alone, under which the
    calibration stays valid (:mod:`.roll`).
    """
    from drumroll.pipeline import estimate

    started = time.perf_counter()
    config = parse_config(raw, path=Path(path) if path else None)
    roll_rng, sound_rng, choice_rng, fit_seed = draw_seeds(options["seed"], index)
    simulator = RollSimulator(config, config.model, options["n_onsets"])
    recorder = Recorder(config) if options["audio"] else None
    fitting = fit_config(config, fit_seed)
    hearing = fit_config(config, fit_seed, numbering=True)
    attempts, rejected = 0, Counter()
    while True:
        roll = simulator.draw(roll_rng)
        attempts += roll.attempts
        rejected.update(roll.rejected)
        if attempts > MAX_ATTEMPTS:
            reason = rejected.most_common(1)[0][0] if rejected else "none"
            raise DrumrollError(f"no roll the estimate takes in {attempts} draws from the "
                                f"priors (the commonest reason: {reason})")
        heard = None
        if recorder is not None:
            try:
                heard = recorder.record(roll, sound_rng)
            except TooSlow:
                rejected[EXTRACTOR_TOO_SLOW] += 1
                continue
            except AudioError:  # the extractor found no roll of 4 onsets: fewer heard
                rejected[TOO_FEW_HEARD] += 1
                continue
            if heard.hearing.n_heard < MIN_ONSETS:
                rejected[TOO_FEW_HEARD] += 1
                continue
        try:
            begun = time.perf_counter()
            result = estimate(_onset_table(roll.times), fitting)
            onset_seconds = time.perf_counter() - begun
            begun = time.perf_counter()
            heard_result = None if heard is None else estimate(heard.onsets, hearing)
            audio_seconds = time.perf_counter() - begun
        except DrumrollError as exc:
            rejected[_refused(exc)] += 1
            continue
        break
    truth = _truths(result.fits[result.model].log_posterior, roll)
    onsets = _fit_record(result, truth, options["rank_draws"], choice_rng, onset_seconds)
    audio = None
    if heard_result is not None:
        audio = _fit_record(heard_result, {**truth, "t0_s": heard.t0}, options["rank_draws"],
                            choice_rng, audio_seconds)
    return DrawRecord(index=index, attempts=attempts, rejected=dict(rejected), truth=truth,
                      onsets=onsets, audio=audio,
                      hearing=None if heard is None else heard.hearing,
                      audio_t0_s=None if heard is None else heard.t0,
                      seconds=time.perf_counter() - started)


def prior_variances(config: Config, n_onsets: int, seed: int, size: int = PRIOR_DRAWS
                    ) -> dict[str, float]:
    """Each reported quantity's variance under the prior, truncated to the points the
    physics allows (the prior the fit uses): ``size`` prior draws through the quantities'
    own computation. T0's prior is flat over a window of :data:`T0_WINDOW_S` about the first
    onset: its variance is that window's, W² / 12."""
    from drumroll.inference.inference_data import parameter_draws
    from drumroll.inference.posterior import LogPosterior
    from drumroll.inference.settings import estimate_settings

    rng = np.random.default_rng(np.random.SeedSequence([seed, 2**31]))
    simulator = RollSimulator(config, config.model, n_onsets)
    space = simulator.space
    x = space.sample_prior(rng, size)
    _, valid = space.impacts(x, simulator.n_flights)
    x = x[valid]
    roll = simulator.draw(rng)  # any roll: the log posterior needs onsets to be built on
    settings = estimate_settings(config)
    log_posterior = LogPosterior.build(config, config.model, OnsetData.from_arrays(roll.times),
                                       settings.noise, settings.nu)
    columns = [x[:, space.names.index(name)] if name in space.names
               else np.full(x.shape[0], roll.t0) for name in log_posterior.space.names]
    with np.errstate(all="ignore"):
        variables, _, _ = parameter_draws(log_posterior, np.stack(columns, axis=-1), rng)
    out = {key: float(np.nanvar(value)) for key, value in variables.items()
           if np.isfinite(value).any()}
    out["t0_s"] = T0_WINDOW_S**2 / 12.0
    return out


def _level(name: str, records: list[FitRecord], truths: list[dict[str, float]],
           parameters: tuple[str, ...], prior_variance: dict[str, float]) -> LevelCalibration:
    """The statistics of one level over every simulation (the quantities every fit has)."""
    keys = set.intersection(*(set(r.rank) for r in records))
    sizes = {r.rank_draws for r in records}
    if len(sizes) != 1:  # ranks among different numbers of draws are on different scales
        raise ValueError(f"the fits ranked their truths among {sorted(sizes)} draws")
    n_ranks = sizes.pop() + 1
    quantities = {}
    for key in report_order(list(keys)):
        ranks = np.array([r.rank[key] for r in records])
        mean = np.array([r.mean[key] for r in records], float)
        sd = np.array([r.sd[key] for r in records], float)
        truth = np.array([t[key] for t in truths], float)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (mean - truth) / sd
            contraction = 1.0 - sd**2 / prior_variance.get(key, math.nan)
        quantities[key] = calibrate_quantity(
            key, ranks, n_ranks,
            [r.covered_50[key] for r in records], [r.covered_90[key] for r in records], z,
            contraction)
    sampled = tuple(k for k in quantities if k in parameters)
    return LevelCalibration(
        level=name, parameters=sampled,
        derived=tuple(k for k in quantities if k not in parameters), quantities=quantities,
        unconverged=sum(not r.converged for r in records),
        inadequate=sum(r.adequate is False for r in records))


def _versions() -> dict[str, str]:
    import emcee
    import scipy

    return {"drumroll": __version__, "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "emcee": emcee.__version__}


def default_workers() -> int:
    """Processes by default: the machine's cores."""
    return os.cpu_count() or 1


def check_calibration(config: Config, n: int, n_onsets: int, audio: bool) -> None:
    """Everything that can be checked before the simulations start, as one-line errors: the
    counts' ranges, the model's priors and noise (a fit is built on one simulated roll), and
    with ``audio`` the ``[simulate]`` sound.

    Raises
    ------
    DrumrollError
        What is wrong, naming the option or key.
    """
    from drumroll.inference.posterior import LogPosterior
    from drumroll.inference.settings import estimate_settings

    if not 1 <= n <= MAX_SIMULATIONS:
        raise DrumrollError(f"--n: the number of simulations must lie in 1 … "
                            f"{MAX_SIMULATIONS}, got {n}")
    if not MIN_ONSETS <= n_onsets <= MAX_ONSETS:
        raise DrumrollError(f"--onsets: a simulated roll must have {MIN_ONSETS} … "
                            f"{MAX_ONSETS} onsets, got {n_onsets}")
    lead = f"{config.path}: " if config.path else ""
    simulator = RollSimulator(config, config.model, n_onsets)
    roll = simulator.draw(np.random.default_rng(0))
    settings = estimate_settings(fit_config(config, 0))
    try:
        LogPosterior.build(config, config.model, OnsetData.from_arrays(roll.times),
                           settings.noise, settings.nu)
    except DrumrollError as exc:
        raise DrumrollError(f"{lead}{exc}", exc.exit_code) from None
    if audio:
        try:
            Recorder(config)
        except DrumrollError as exc:
            raise DrumrollError(f"{lead}{exc}", exc.exit_code) from None


def calibrate(config: Config | str | os.PathLike[str], n: int = 200, *,
              n_onsets: int = DEFAULT_ONSETS, seed: int = 0, audio: bool = False,
              rank_draws: int = RANK_DRAWS, workers: int | None = None,
              executor: Executor | None = None, progress: ProgressLike = None
              ) -> CalibrationResult:
    """Simulation-based calibration of ``estimate`` on a config's main model (Talts et al.
    2018; see the module docstring).

    Parameters
    ----------
    config
        A :class:`~drumroll.config.Config` or the path of a TOML config: the model, the priors
        θ is drawn from, the noise, the sampler's settings (and for ``audio`` the
        ``[simulate]`` sound).
    n
        Simulations.
    n_onsets
        Onsets per simulated roll (bounces 0 … n_onsets − 1).
    seed
        Every simulation's seeds derive from it and the simulation's number.
    audio
        Also render each roll as a recording, extract its onsets and fit them: the
        result's :attr:`~CalibrationResult.audio`.
    rank_draws
        L: the posterior draws each truth is ranked among.
    workers
        Processes when no ``executor`` is given (default: the cores; 1 runs here).
    executor
        Any :class:`concurrent.futures.Executor` (a Dask client's ``get_executor()``); the
        caller owns it.
    progress
        Where the calibration reports (:func:`drumroll.progress.as_progress`): None shows a
        bar of the simulations where a person watches (a terminal, a notebook), a callable
        gets a line of news now and then, False nothing; or a
        :class:`~drumroll.progress.Progress`.

    Returns
    -------
    CalibrationResult
        Per quantity: rank histogram and its χ² test, 50 % and 90 % coverage, mean z-score,
        contraction; every simulation's numbers.

    Raises
    ------
    DrumrollError
        A bad count, config or sound (before any simulation), or a simulation that failed
        (one line naming it).
    """
    reporter = as_progress(progress)
    say = reporter.say
    started = time.perf_counter()
    if not isinstance(config, Config):
        config = load_config(config)
    if seed < 0:
        raise DrumrollError(f"--seed: must not be negative, got {seed}")
    if rank_draws < 1:
        raise DrumrollError(f"rank_draws: must be at least 1, got {rank_draws}")
    check_calibration(config, n, n_onsets, audio)
    from drumroll.inference.settings import estimate_settings

    sampler = dict(vars(estimate_settings(config).sampler))
    sampler.pop("seed", None)
    settings = CalibrationSettings(model=config.model, n=n, n_onsets=n_onsets,
                                   rank_draws=rank_draws, seed=seed, audio=audio,
                                   sound="config" if "simulate" in config.raw else "default",
                                   noise=estimate_settings(config).noise, sampler=sampler)
    options = {"n_onsets": n_onsets, "rank_draws": rank_draws, "seed": seed, "audio": audio}
    path = None if config.path is None else str(config.path)
    records: dict[int, DrawRecord] = {}
    report_every = max(1, n // 20)

    def finish(record: DrawRecord) -> None:
        records[record.index] = record
        bar.advance(note=f"simulation {record.index}")
        if len(records) % report_every == 0 or len(records) == n:
            say(f"{len(records)}/{n} simulations fitted ({time.perf_counter() - started:.0f} s)")

    count = max(1, min(workers or default_workers(), n))
    what = "rolls, rendered and heard," if audio else "rolls"
    say(f"{n} simulated {what} of {n_onsets} onsets, fitted with the {config.model} model "
        + (f"on {type(executor).__name__}" if executor is not None else
           f"in {count} process{'es' if count > 1 else ''}"))
    with reporter.bar(n, "calibrate", "simulation") as bar:
        if executor is None and count == 1:
            for i in range(n):
                try:
                    record = run_draw(config.raw, path, i, options)
                except DrumrollError as exc:
                    raise _named(i, exc) from None
                finish(record)
        elif executor is not None:
            _run_all(executor, config.raw, path, n, options, finish)
        else:
            with process_pool(count) as pool:
                _run_all(pool, config.raw, path, n, options, finish)
    draws = tuple(records[i] for i in range(n))
    variance = prior_variances(config, n_onsets, seed)
    # The fit samples the simulator's parameters and T0 (sampled, or drawn from its
    # conditional under Gaussian noise): those are the parameters, the rest derived.
    sampled = RollSimulator(config, config.model, n_onsets).space.names
    parameters = (*(BY_NAME[name].key for name in sampled), "t0_s")
    truths = [d.truth for d in draws]
    levels = {"onsets": _level("onsets", [d.onsets for d in draws], truths, parameters,
                               variance)}
    if audio:
        levels["audio"] = _level("audio", [d.audio for d in draws],
                                 [{**d.truth, "t0_s": d.audio_t0_s} for d in draws], parameters,
                                 variance)
    rejected: Counter[str] = Counter()
    for d in draws:
        rejected.update(d.rejected)
    return CalibrationResult(
        settings=settings, onsets=levels["onsets"], audio=levels.get("audio"), draws=draws,
        prior_variance=variance, attempts=sum(d.attempts for d in draws),
        rejected=dict(rejected.most_common()), config=config.raw, config_path=path,
        versions=_versions(), seconds=time.perf_counter() - started,
        cpu_seconds=sum(d.seconds for d in draws))


def _named(index: int, exc: DrumrollError) -> DrumrollError:
    """``exc`` as one line naming the simulation it came from."""
    return DrumrollError(f"simulation {index}: {exc}", exc.exit_code)


def _run_all(executor: Executor, raw: dict[str, Any], path: str | None, n: int,
             options: dict[str, Any], finish: Callable[[DrawRecord], None]) -> None:
    """Submit every simulation; hand each record to ``finish`` as it completes. A failure
    (or Ctrl-C) cancels the simulations not started and is raised."""
    futures: dict[Future, int] = {executor.submit(run_draw, raw, path, i, options): i
                                  for i in range(n)}
    try:
        for future in as_completed(futures):
            try:
                record = future.result()
            except DrumrollError as exc:
                raise _named(futures[future], exc) from None
            finish(record)
    except BaseException:
        for future in futures:
            future.cancel()
        raise
