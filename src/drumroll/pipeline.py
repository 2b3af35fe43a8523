"""``drumroll.estimate``: from a recording (or onset file) to posteriors and a comparison.

The data's path: onsets (:mod:`drumroll.onsets`) → the roll to fit (:func:`choose_roll`: one
roll of the recording, its bounce numbers counted from its first onset) → log posterior of
each model
(:class:`~drumroll.inference.posterior.LogPosterior`) → ensemble MCMC
(:func:`~drumroll.inference.sampling.run_emcee`) and, for Bayes factors, ln Z
(:func:`~drumroll.inference.evidence.choose_evidence`: importance sampling checked by its
Pareto k, dynesty where that fails) → the groups of ArviZ InferenceData
(:class:`~drumroll.inference.draws.Draws`) → PSIS-LOO comparison and verdict →
:class:`Result`, which :mod:`drumroll.outputs` writes to disk. ArviZ itself is imported
only when a caller asks for InferenceData (:attr:`Result.idatas`).
"""

from __future__ import annotations

import importlib
import math
import os
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Executor, wait
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from drumroll._version import __version__
from drumroll.audio.io import AudioSource
from drumroll.config import Config, load_config
from drumroll.errors import DrumrollError
from drumroll.inference.draws import Draws
from drumroll.inference.evidence import Evidence, choose_evidence
from drumroll.inference.inference_data import build_draws, parameter_draws
from drumroll.inference.likelihood import OnsetData
from drumroll.inference.missed_impacts import (
    EVIDENCE_ONLY_ESS,
    STRAY,
    Numberings,
    importance_sample,
    missed_note,
    missed_probabilities,
    missed_warning,
    mixed_numberings,
    needs_fit,
    numbering_average,
    renumbering,
    screen,
    shifted,
    stray_log_density,
    stray_note,
    stray_warning,
    unheard,
)
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.results import (
    Adequacy,
    Diagnostics,
    EvidenceSummary,
    ModelSummary,
    ObservedFlights,
    Onset,
    ParameterSummary,
    Summary,
)
from drumroll.inference.sampling import Chain, run_emcee
from drumroll.inference.settings import EstimateSettings, estimate_settings
from drumroll.inference.space import ParameterSpace
from drumroll.onsets import ONSET_FILE_SUFFIXES, OnsetTable, detect, read_onsets
from drumroll.physics import STANDARD_GRAVITY
from drumroll.physics.models import forward_model
from drumroll.progress import Progress, ProgressLike, as_progress
from drumroll.quantities import BY_NAME
from drumroll.reporting.numbers import format_value_error
from drumroll.workers import process_pool

if TYPE_CHECKING:  # ArviZ is imported only for Result.idatas
    import arviz as az

    from drumroll.inference.comparison import LooResult

#: Fewest onsets that can constrain a model (three flights).
MIN_ONSETS = 4
#: A flight longer than this is no bounce a recording holds: T = 2v/g = 10 s is a rebound
#: 123 m high at 49 m/s. Onsets this far apart per bounce are times in another unit (a list
#: in milliseconds is a thousand times too slow), which the Student-t noise would otherwise
#: fit with every parameter at its prior's edge and no error.
LONGEST_FLIGHT_S = 10.0
#: Posterior draws stored per model in posterior.nc and drawn in the figures (beyond this the
#: chain is thinned further, and the InferenceData says by how much); every summary, R-hat and
#: ESS is computed on all draws before.
MAX_DRAWS = 3000


@dataclass
class ModelFit:
    """One model's fit: its posterior, chain, draws in InferenceData's groups (thinned to at
    most :data:`MAX_DRAWS` draws), evidence (with its check), and the summaries of its
    posterior variables computed on every draw."""

    model: str
    log_posterior: LogPosterior
    chain: Chain
    draws: Draws
    evidence: Evidence | None
    evidence_check: Evidence | None
    seconds: dict[str, float]
    stats: dict[str, ParameterSummary] = field(default_factory=dict)
    _idata: Any = field(default=None, init=False, repr=False, compare=False)

    @property
    def idata(self) -> az.InferenceData:
        """:attr:`draws` as an :class:`arviz.InferenceData` (made, and ArviZ imported, on
        first use)."""
        if self._idata is None:
            self._idata = self.draws.to_inference_data()
        return self._idata


@dataclass
class Result:
    """Everything ``estimate`` learned (and what ``summary.json`` holds).

    Attributes
    ----------
    summary
        What was found (:class:`~drumroll.inference.results.Summary`; ``summary.json`` is its
        :meth:`~drumroll.inference.results.Record.to_json`).
    fits
        Model name → :class:`ModelFit`, main model first.
    onsets
        The onsets that were fitted: one roll, bounce numbers counted from its first onset
        (``summary.roll`` says which roll of the source, ``summary.notes`` what else the user
        should know about it).
    config
        The config used.
    source
        The recording or onset file, if read from disk.
    seconds
        Wall time by stage.
    loos
        PSIS-LOO of each model (computed on every draw; the figures reuse it).
    """

    summary: Summary
    fits: dict[str, ModelFit]
    onsets: OnsetTable
    config: Config
    source: Path | None
    seconds: dict[str, float] = field(default_factory=dict)
    loos: dict[str, LooResult] = field(default_factory=dict)

    @property
    def model(self) -> str:
        """The main model."""
        return self.summary.model

    @property
    def preferred(self) -> str | None:
        """The model the comparison prefers (None: the data cannot tell)."""
        return self.summary.preferred

    @property
    def idatas(self) -> dict[str, az.InferenceData]:
        """Model name → InferenceData (thinned to at most :data:`MAX_DRAWS` draws; ArviZ is
        imported on first use)."""
        return {name: fit.idata for name, fit in self.fits.items()}

    @property
    def draws(self) -> dict[str, Draws]:
        """Model name → the same groups as :attr:`idatas`, as :class:`Draws` (what the
        outputs are written from)."""
        return {name: fit.draws for name, fit in self.fits.items()}

    def parameter(self, name: str) -> ParameterSummary:
        """The main model's summary of one quantity (``alpha``, ``t_b``, …)."""
        return self.summary.parameters[name]

    def figure(self, name: str = "bounce_series"):
        """Figure ``name`` as a :class:`matplotlib.figure.Figure` (a notebook shows it
        inline): ``onsets``, ``bounce_series``, ``residuals``, ``comparison``, ``corner`` or
        ``trace``, as ``drumroll estimate`` writes them
        (:func:`drumroll.reporting.display.estimate_figure`)."""
        from drumroll.reporting.display import estimate_figure

        return estimate_figure(self, name)

    def __repr__(self) -> str:
        summary = self.summary
        source = f" of {self.source.name}" if self.source is not None else ""
        found = [f"{key} = {format_value_error(p.mean, p.sd)}"
                 for key in ("alpha", "t_b") if (p := summary.parameters.get(key)) is not None
                 and p.mean is not None and p.sd is not None]
        preferred = summary.preferred or "none"
        return (f"<drumroll estimate{source}: {summary.model}, {summary.n_onsets} onsets; "
                f"{', '.join(found)}; preferred model: {preferred}>")

    # The rich displays of a notebook (imported only when shown).
    def _repr_html_(self) -> str:
        from drumroll.reporting.display import estimate_display, to_html

        return to_html(estimate_display(self))

    def _repr_markdown_(self) -> str:
        from drumroll.reporting.display import estimate_display, to_markdown

        return to_markdown(estimate_display(self, figure=False))


@dataclass(frozen=True)
class MainFit:
    """The main model's fit as soon as it is known, before the other models are (see
    :class:`EstimateListener`).

    Attributes
    ----------
    model
        The main model.
    draws
        Its draws as stored and drawn: thinned to at most :data:`MAX_DRAWS`.
    parameters
        The summaries of its posterior variables, computed on every draw (those of
        ``summary.json``).
    max_r_hat
        The R-hat target (``[sampler] max_r_hat``).
    log_posterior
        Its posterior (the noise model the figures' true values are drawn in).
    """

    model: str
    draws: Draws
    parameters: dict[str, ParameterSummary]
    max_r_hat: float
    log_posterior: LogPosterior


class EstimateListener:
    """What :func:`estimate` tells a caller as its results appear, so that outputs can be
    made while the rest is still being computed (the command line draws figures while the
    other models are sampled). Each hook does nothing here; a subclass overrides what it needs.
    The hooks run in the estimate's process; an exception they raise ends the estimate.
    """

    def sampling(self, onsets: OnsetTable, recording: Path | AudioSource | None) -> None:
        """Called once while the models are sampled in worker processes (or, with one
        process, after the first model): the fitted roll's onsets and the recording they came
        from (None for an onset file)."""

    def main_fit(self, fit: MainFit) -> None:
        """Called once the main model's draws and their summaries are known."""


def load_onsets(source: str | os.PathLike[str] | OnsetTable, **options: Any) -> OnsetTable:
    """Onsets from an onset file (CSV, Audacity labels, plain text) or by detection in audio."""
    if isinstance(source, OnsetTable):
        return source
    path = Path(source)
    if path.suffix.lower() in ONSET_FILE_SUFFIXES:
        return read_onsets(path)
    return detect(path, **options)


@dataclass(frozen=True)
class FittedRoll:
    """The roll of a recording that ``estimate`` fits.

    Attributes
    ----------
    onsets
        The roll's onsets, bounce numbers counted from its first onset (k = 0).
    data
        The same onsets as the likelihood takes them, counted from the first onset.
    numbered_from
        The first onset's bounce number in the source: the impacts its maker says were not
        heard before it (0 for an extractor's onsets), the numbering every model is first
        fitted with (``data`` shifted by it).
    roll
        The roll's number in the source (0, 1, 2, … in time order).
    name
        What the source is called in notes.
    dropped_stray
        Where the source's first onset was dropped as no impact of the roll
        (:meth:`without_first`): the probability it was, else None.
    given_notes
        The notes ``notes`` began with (the choice of roll; a dropped first onset), before
        those on the roll's own onsets.
    sizes
        Onsets per roll of the source, by roll number.
    notes
        What the user should read before the numbers: other rolls in the recording, the
        first onset's number, missing bounces.
    """

    onsets: OnsetTable
    data: OnsetData
    roll: int
    sizes: dict[int, int]
    notes: list[str]
    numbered_from: int = 0
    name: str = "the onsets"
    dropped_stray: float | None = None
    given_notes: tuple[str, ...] = ()

    def without_first(self, note: str, probability: float) -> FittedRoll:
        """The roll from its second onset on, numbered from it (k = 0), its first onset
        taken for a sound that is no impact (:data:`~.missed_impacts.STRAY`, with
        ``probability``, told in ``note``)."""
        table = self.onsets
        rest = replace(table, time_s=table.time_s[1:], amplitude=table.amplitude[1:],
                       snr_db=table.snr_db[1:], sigma_s=table.sigma_s[1:],
                       bounce=table.bounce[1:] - table.bounce[1], roll=table.roll[1:])
        # The notes on its numbering, gaps and first onset's level are the new roll's own.
        return replace(_fitted_roll(rest, self.roll, self.sizes, [*self.given_notes, note],
                                    self.name), dropped_stray=probability)


def choose_roll(onsets: OnsetTable, roll: int | None = None, name: str = "the onsets"
                ) -> FittedRoll:
    """The roll to fit: roll ``roll``, or the longest (the earliest of those tied).

    Bounce numbers are kept as the source gives them: an extractor numbers a roll's first
    onset k = 0, a user's file may start at k > 0 (impacts its maker knows were not heard),
    and every model is first fitted with that numbering (``numbered_from``; the stick models
    then weigh it against the others, :mod:`~drumroll.inference.missed_impacts`). A missing
    number is an impact that was not heard, fitted as a gap: the model runs through it, and
    the onsets after it keep their own k.

    Raises
    ------
    DrumrollError
        ``roll`` is not a roll of ``onsets`` (one line naming ``name``).
    """
    sizes = onsets.roll_sizes()
    if not sizes:
        raise DrumrollError(f"{name}: holds no onsets")
    if roll is not None and roll not in sizes:
        present = ", ".join(map(str, sizes))
        raise DrumrollError(f"{name}: no roll {roll}; the recording holds "
                            f"roll{'s' if len(sizes) > 1 else ''} {present} (--roll counts "
                            "from 0)")
    chosen = onsets.longest_roll if roll is None else roll
    notes = []
    if len(sizes) > 1:
        counts = ", ".join(str(c) for c in sizes.values())
        why = ("the longest; choose another with --roll N" if roll is None
               else "as asked")
        notes.append(f"the recording holds {len(sizes)} rolls (onsets {counts}); fitting roll "
                     f"{chosen}, {why}")
    return _fitted_roll(onsets.select_roll(chosen), int(chosen), sizes, notes, name)


def _fitted_roll(table: OnsetTable, chosen: int, sizes: dict[int, int], notes: list[str],
                 name: str) -> FittedRoll:
    """The roll ``table`` as it is fitted, with ``notes`` and those on its numbering, its
    missing bounces and its first onset's level."""
    data = OnsetData.from_arrays(table.time_s, table.sigma_s, table.bounce)
    given = tuple(notes)
    notes = list(notes)
    first = int(table.bounce[0])
    if first:
        notes.append(f"the roll's first onset is numbered bounce {first} in {name}, which "
                     f"counts {unheard(first)} of the roll as not heard: the fit starts from "
                     "that numbering")
        table = replace(table, bounce=data.bounces)
    missing = data.missing
    if missing:
        listed = ", ".join(map(str, missing))
        notes.append(f"bounce{'s' if len(missing) > 1 else ''} {listed} missing (inaudible or "
                     f"masked): fitted as gap{'s' if len(missing) > 1 else ''}")
    notes.extend(_faint_first_notes(table))
    return FittedRoll(onsets=table, data=data, roll=chosen, sizes=sizes, notes=notes,
                      numbered_from=first, name=name, given_notes=given)


#: How far (dB) a roll's first onset may lie under the median level of the three after it
#: before the fit says it may not be an impact of the roll. The first impact is struck
#: fastest, so it is rarely much fainter than the next: over the shared corpus's 12 rolls of
#: real snare, claves and ball hits and the real ping-pong, the first onset lay at most 14 dB
#: under them (a ball glancing off the claves; the others 7 dB or less), while of the sounds
#: before simulated rolls (table2_h80's [simulate], 40 recordings) that the extractor took
#: for a first bounce, two lay 29 and 33 dB under (a tap, and a sound 37 ms before another
#: tap) and one tap 4 dB under, which its level cannot tell. A fainter first onset is a sound
#: to check, not one to drop: the fit keeps it.
FAINT_FIRST_DB = 20.0


def _faint_first_notes(table: OnsetTable) -> list[str]:
    """A note when the roll's first onset is :data:`FAINT_FIRST_DB` or more under the median
    level of the three onsets after it (a tap or a stray sound taken for the first bounce
    numbers every bounce one too high); none where the levels are unknown."""
    amplitude = np.asarray(table.amplitude, float)
    if amplitude.size < 4:
        return []
    after = float(np.median(amplitude[1:4]))
    if not (math.isfinite(after) and after > 0.0 and amplitude[0] > 0.0):
        return []  # a level of 0 or none in an onset file: unknown, not silent
    below = 20.0 * math.log10(after / amplitude[0])
    if below < FAINT_FIRST_DB:
        return []
    return [f"the first onset ({table.time_s[0]:.4f} s) is {below:.0f} dB fainter than "
            "the three after it, where a roll's first impact, struck fastest, is rarely more "
            "than 15 dB under them: if it is a tap or another sound before the roll, delete its "
            "row from the onset table (drumroll onsets -o onsets.csv) and estimate from that "
            "table"]


def _fit(log_posterior: LogPosterior, settings: EstimateSettings, seed: int
         ) -> tuple[Chain, Evidence | None, Evidence | None, dict[str, float]]:
    """Sample one model's ``log_posterior``, and its evidence as ``[sampler] evidence`` asks;
    runs in a worker process (the log posterior is built once, by the caller, and pickled).

    Returns the chain, the evidence used and the other estimate when one was made (see
    :func:`~drumroll.inference.evidence.choose_evidence`; both None without evidence), and
    the seconds each stage took.
    """
    started = time.perf_counter()
    chain = run_emcee(log_posterior, replace(settings.sampler, seed=seed),
                      reported=partial(reported_draws, log_posterior, seed))
    seconds = {"emcee": time.perf_counter() - started}
    evidence = check = None
    if settings.evidence != "none":
        started = time.perf_counter()
        evidence, check = choose_evidence(log_posterior, chain.samples, settings.evidence,
                                          seed=seed, n_live=settings.live_points,
                                          atoms=chain.atoms)
        seconds["evidence"] = time.perf_counter() - started
    return chain, evidence, check, seconds


def reported_draws(log_posterior: LogPosterior, seed: int, draws: np.ndarray
                   ) -> dict[str, np.ndarray]:
    """Every quantity the report gives for ``draws``, exactly as :func:`estimate` computes them
    (the same generator for T0's conditional draws), so that the sampler's stopping check
    sees the reported numbers themselves."""
    return parameter_draws(log_posterior, draws, np.random.default_rng(seed))[0]


def evidence_summary(evidence: Evidence, check: Evidence | None
                     ) -> tuple[EvidenceSummary, str | None]:
    """The summary of one model's evidence, and a warning if the two independent estimates
    (nested sampling, importance sampling) disagree."""
    entry = EvidenceSummary(log_z=evidence.log_z, log_z_err=evidence.log_z_err,
                            method=evidence.method, n_calls=evidence.n_calls)
    if evidence.method == "importance":
        entry = replace(entry, pareto_k=evidence.pareto_k, importance_ess=evidence.ess)
    if check is None:
        return entry, None
    entry = replace(entry, importance_log_z=check.log_z, importance_log_z_err=check.log_z_err,
                    importance_ess=check.ess, pareto_k=check.pareto_k,
                    fallback=check.failure if check.method == "importance" else None)
    if check.method == "importance" and not check.trusted:
        return entry, None  # the cheap estimate failed its own check: nothing to compare
    tolerance = 3.0 * math.hypot(evidence.log_z_err, check.log_z_err)
    if abs(evidence.log_z - check.log_z) <= tolerance:
        return entry, None
    return entry, (f"ln Z by nested sampling ({evidence.log_z:.2f} ± {evidence.log_z_err:.2f}) "
                   f"and by importance sampling ({check.log_z:.2f} ± {check.log_z_err:.2f}) "
                   "disagree: treat the Bayes factors with care")


def thin_draws(draws: Draws, max_draws: int) -> Draws:
    """Keep every k-th draw (latest last) so that at most ``max_draws`` remain per model."""
    chains, n = draws.posterior.sizes["chain"], draws.posterior.sizes["draw"]
    step = -(-chains * n // max_draws)  # ceiling division
    if step <= 1:
        draws.posterior.attrs.update(stored_every=1, draws_before_storing=chains * n)
        return draws
    thinned = draws.thinned(np.arange((n - 1) % step, n, step))
    thinned.sample_stats.attrs["thin"] = int(draws.sample_stats.attrs.get("thin", 1)) * step
    # Say how the stored draws were chosen, where a reader of posterior.nc looks first.
    thinned.posterior.attrs.update(stored_every=step, draws_before_storing=chains * n)
    return thinned


def _summarised(draws: Draws, hdi_prob: float) -> dict[str, ParameterSummary]:
    """The summaries of every posterior variable of ``draws`` (on every draw), also written
    into the variables' attributes: every draw's R-hat and ESS travel with the variables to
    the readers of posterior.nc, whose draws are thinned."""
    from drumroll.inference.summary import parameter_summary

    stats = parameter_summary(draws, hdi_prob)
    for name, values in draws.posterior.data_vars.items():
        values.attrs.update({key: getattr(stats[name], key) for key in (
            "r_hat", "ess_bulk", "ess_tail") if getattr(stats[name], key) is not None})
    return stats


def model_seed(base: int, index: int) -> int:
    """An independent, reproducible seed for the ``index``-th model of a run."""
    return int(np.random.SeedSequence([base, index]).generate_state(1)[0])


def _while_sampling(listener: EstimateListener | None, onsets: OnsetTable,
                    recording: Path | AudioSource | None) -> None:
    """What this process does while the workers sample: import what the rest of
    :func:`estimate` needs, then tell the ``listener``."""
    importlib.import_module("drumroll.inference.comparison")
    importlib.import_module("drumroll.inference.summary")
    if listener is not None:
        listener.sampling(onsets, recording)


def _release_notes(space: ParameterSpace) -> list[str]:
    """What the fall time rests on when the release is fixed rather than sampled: a roll
    does not observe its release (5 cm/s of release speed changes t_C by about 5 ms and t_B
    by 0.2 ms on the paper's set-up), so t_C's error bar is then conditional on it."""
    if not space.forward.needs_stick:
        return []
    fixed = [BY_NAME[n] for n in ("release_speed", "release_angle") if space.priors[n].is_fixed]
    if not fixed:
        return []
    held = " and ".join(f"{q.key} = {q.to_user(space.priors[q.name].value):g}" for q in fixed)
    return [f"t_c assumes the release this config fixes ({held}): a roll does not observe its "
            "release, so t_c's interval holds only if the stick was released so; give "
            f"{' and '.join(q.key for q in fixed)} a prior to carry that uncertainty"]


def _predicted_prior_notes(config: Config, spaces: dict[str, ParameterSpace]) -> list[str]:
    """Which priors the set-up predicted rather than the config gave (the power law's t_B
    from the geometry: :func:`~drumroll.inference.space.default_prior`)."""
    notes = []
    for model, space in spaces.items():
        if "t_b" in space.priors and not config.has_prior("t_b"):
            prior = space.priors["t_b"]
            notes.append(f"{model}: t_b's prior is the set-up's prior predictive (the exact "
                         f"pendulum from the [stick] and [priors]): lognormal with median "
                         f"{prior.median():.4g} s and {100 * prior.sigma:.2g} % sd")
    return notes


def estimate(source: str | os.PathLike[str] | OnsetTable, config: Config | str | os.PathLike[str],
             *, roll: int | None = None, progress: ProgressLike = None,
             listener: EstimateListener | None = None, **onset_options: Any) -> Result:
    """Posteriors of every model in the config, and their comparison.

    Parameters
    ----------
    source
        A recording (anything soundfile or FFmpeg reads: see :mod:`drumroll.audio.io`), an
        onset file (our CSV, Audacity labels, one time per line) or an
        :class:`~drumroll.onsets.OnsetTable`.
    config
        A :class:`~drumroll.config.Config` or the path of a TOML config.
    roll
        Which roll of the source to fit (0, 1, 2, … in time order); default the longest
        (see :func:`choose_roll`).
    progress
        Where the estimate reports its stages (:func:`drumroll.progress.as_progress`): None
        shows a bar of the fits sampled where a person watches (a terminal, a notebook)
        and nothing elsewhere; False nothing; a callable is called with a line of news at
        each stage (the command line prints them on stderr); or a
        :class:`~drumroll.progress.Progress`.
    listener
        Told of results as they appear (:class:`EstimateListener`: the command line starts
        drawing figures while models are still sampled).
    onset_options
        Passed to :func:`drumroll.onsets.detect` when ``source`` is audio (``stream=N``: which
        audio stream of the file).

    Returns
    -------
    Result
        Summary, fits (InferenceData per model), onsets.
    """
    reporter = as_progress(progress)
    say = reporter.say
    if not isinstance(config, Config):
        config = load_config(config)
    settings = estimate_settings(config)
    seconds: dict[str, float] = {}
    started = time.perf_counter()
    name = "the onsets" if isinstance(source, OnsetTable) else str(source)
    fitted = choose_roll(load_onsets(source, **onset_options), roll, name)
    onsets = fitted.onsets
    seconds["onsets"] = time.perf_counter() - started
    of_roll = f" in roll {fitted.roll}" if len(fitted.sizes) > 1 else ""
    if len(onsets) < MIN_ONSETS:
        raise DrumrollError(f"{name}: only {len(onsets)} onsets{of_roll}; at least "
                            f"{MIN_ONSETS} are needed to estimate anything")
    per_bounce = float(np.median(np.diff(onsets.time_s) / np.diff(fitted.data.bounces)))
    if per_bounce > LONGEST_FLIGHT_S:
        raise DrumrollError(f"{name}: the onsets{of_roll} are {per_bounce:g} s apart per bounce "
                            f"(median), longer than any bounce's flight ({LONGEST_FLIGHT_S:g} s "
                            f"is a rebound of {STANDARD_GRAVITY * LONGEST_FLIGHT_S**2 / 8:.0f} "
                            "m): are the times in seconds? (milliseconds must be divided by "
                            "1000)")
    say(f"{len(onsets)} onsets{of_roll}, from {onsets.time_s[0]:.4f} s to "
        f"{onsets.time_s[-1]:.4f} s")
    recording = None if isinstance(source, OnsetTable) else Path(source)
    if recording is not None and onset_options.get("stream") is not None:
        # The onset figure reads the audio stream the onsets came from.
        recording = AudioSource(recording, onset_options["stream"])

    source_name = None if isinstance(source, OnsetTable) else str(source)
    numberings = Numberings()
    begun = time.perf_counter()
    numbered_from, first_pass, stray = fitted.numbered_from, True, True
    while True:
        try:
            return _fit_models(config, settings, fitted, recording, numberings,
                               reporter=reporter, listener=listener, seconds=seconds,
                               source=source_name, numbered_from=numbered_from,
                               first_pass=first_pass, stray=stray)
        except _Renumber as renumber:
            # The first onset's numbering fitted the main model worse than another: every
            # number of these fits would carry that misfit, so the models are fitted again.
            seconds["first_numbering"] = time.perf_counter() - begun
            if renumber.numbered_from == STRAY:
                # A new roll, the onsets after the first: its own numberings are weighed
                # afresh (its first impact may have gone unheard too); once only.
                say(f"{config.model}: the first onset is likelier a sound that is no impact "
                    f"of the roll ({renumber.why}): fitting every model again from the onset "
                    "after it")
                fitted = fitted.without_first(stray_note(
                    float(fitted.onsets.time_s[0]), renumber.probability, config.model),
                    renumber.probability)
                numberings, numbered_from, stray = Numberings(), fitted.numbered_from, False
                continue
            say(f"{config.model}: the first onset is likelier impact {renumber.numbered_from} "
                f"than impact {numbered_from} ({renumber.why}): fitting every model again "
                "with that numbering")
            numbered_from, first_pass = renumber.numbered_from, False


#: Draws taken from a numbering's importance sample for the average over the numberings.
RESAMPLED = 4000


def _variables(draws: Draws) -> dict[str, np.ndarray]:
    """A fit's posterior draws by quantity key (every draw)."""
    return {name: np.asarray(values) for name, values in draws.posterior.data_vars.items()}


def _sampled_draws(log_posteriors: dict[int, LogPosterior], settings: EstimateSettings,
                   seed: int, workers: int) -> dict[int, dict[str, np.ndarray]]:
    """Each numbering's draws of the main model (numbering → quantity key → array), sampled
    as the main fit is (``workers`` processes side by side)."""
    def variables(missed: int, chain: Chain) -> dict[str, np.ndarray]:
        return parameter_draws(log_posteriors[missed], chain.samples,
                               np.random.default_rng(seed))[0]

    if workers == 1 or len(log_posteriors) == 1:
        return {m: variables(m, _fit(lp, settings, seed)[0]) for m, lp in log_posteriors.items()}
    with process_pool(min(workers, len(log_posteriors))) as pool:
        futures = {m: pool.submit(_fit, lp, settings, seed) for m, lp in log_posteriors.items()}
        return {m: variables(m, future.result()[0]) for m, future in futures.items()}


def _given_an_impact(probabilities: tuple[float, ...]) -> tuple[float, ...]:
    """P(m impacts missed) renormalised over m = 0, 1, …: given that the first onset is an
    impact of the roll (the rest of the probability is its being a stray sound)."""
    total = sum(probabilities)
    return tuple(p / total for p in probabilities) if total > 0.0 else probabilities


class _Renumber(Exception):
    """Raised out of the first pass of :func:`_fit_models`: fit with another numbering."""

    def __init__(self, numbered_from: int, why: str, probability: float) -> None:
        super().__init__(numbered_from)
        self.numbered_from, self.why, self.probability = numbered_from, why, probability


def _fit_models(config: Config, settings: EstimateSettings, fitted: FittedRoll,
                recording: Path | AudioSource | None, numberings: Numberings, *,
                reporter: Progress, listener: EstimateListener | None,
                seconds: dict[str, float], source: str | None,
                numbered_from: int = 0, first_pass: bool = True, stray: bool = False
                ) -> Result:
    """:func:`estimate`'s fits, comparison and summary of the roll ``fitted``, its first onset
    numbered as impact ``numbered_from``. In the first pass (the source's numbering), raises
    :class:`_Renumber` as soon as the numberings' evidences put another numbering ahead
    (:func:`~drumroll.inference.missed_impacts.renumbering`); the numberings' screens and
    the ln Z they settled stay in ``numberings`` for the next pass, which screens none of them
    again and fits only those the first pass left open. With ``stray`` (in the first pass),
    the first onset's being no impact (:data:`~.missed_impacts.STRAY`) is weighed with the
    numberings, for every main model: its timing and level tell, not the geometry."""
    say = reporter.say
    onsets, data = fitted.onsets, shifted(fitted.data, numbered_from)
    models = config.models
    workers = max(1, min(settings.workers, len(models)))
    evidence_note = {"auto": "with evidences, ", "nested": "with evidences by nested sampling, ",
                     "none": ""}[settings.evidence]
    say(f"sampling {', '.join(models)} ({evidence_note}{workers} "
        f"process{'es' if workers > 1 else ''})")
    started = time.perf_counter()
    seeds = dict(zip(models, (model_seed(settings.sampler.seed, i) for i in range(len(models))),
                     strict=True))
    posteriors = {m: LogPosterior.build(config, m, data, settings.noise, settings.nu)
                  for m in models}
    fits: dict[str, ModelFit] = {}
    loos: dict[str, LooResult] = {}
    checked: dict[str, Adequacy] = {}
    base_diagnostics: dict[str, Diagnostics] = {}
    summaries: dict[str, ModelSummary] = {}
    observed: dict[str, ObservedFlights] = {}  # the main model's
    every_draw: dict[str, Draws] = {}
    post_seconds = 0.0

    def finish(model: str, output: tuple, executor: Executor | None = None,
               idle: Callable[[], int] | None = None) -> None:
        """Everything of a model that needs no other model (its draws, PSIS-LOO, adequacy,
        summaries and diagnostics on every draw, and the thinned draws that are stored), as
        soon as its fit is back: this process is otherwise idle while the others sample, and
        only the comparison is left when the last one is back. ``executor``: the fits'
        processes, ``idle()`` of them without a fit, to share LOO's Laplace estimates with (a
        scattering restitution under Student-t noise: :func:`build_draws`)."""
        nonlocal post_seconds
        from drumroll.inference.adequacy import adequacy
        from drumroll.inference.comparison import loo
        from drumroll.inference.summary import (
            diagnostics,
            flight_series,
            observed_flights,
            onset_residuals,
        )

        begun = time.perf_counter()
        chain, evidence, check, fit_seconds = output
        log_posterior = posteriors[model]
        # The same generator as reported_draws: the stopping check saw these very numbers.
        draws = build_draws(log_posterior, chain, np.random.default_rng(seeds[model]),
                            executor=executor, idle=idle)
        fit = fits[model] = ModelFit(model, log_posterior, chain, draws, evidence, check,
                                     fit_seconds)
        loos[model] = loo(draws)
        checked[model] = adequacy(draws, log_posterior=log_posterior,  # on every draw
                                  parameters=chain.samples)
        fit.stats = _summarised(draws, settings.hdi_prob)
        base_diagnostics[model] = diagnostics(draws, chain, loos[model], settings)
        summaries[model] = ModelSummary(
            parameters=fit.stats, flights=flight_series(draws, settings.hdi_prob),
            residuals=onset_residuals(draws, settings.hdi_prob), adequacy=checked[model])
        if model == config.model:
            observed[model] = observed_flights(draws)
        # Diagnostics and summaries above use every draw, as do the comparison's prior
        # sensitivity and model average (every_draw, until then); what is stored and drawn is
        # thinned.
        every_draw[model] = draws
        fit.draws = thin_draws(draws, MAX_DRAWS)
        if model == config.model and listener is not None:
            # Its figures can be drawn while the other models are sampled.
            listener.main_fit(MainFit(model, fit.draws, fit.stats, settings.sampler.max_r_hat,
                                      log_posterior))
        post_seconds += time.perf_counter() - begun

    # The stick models' discrete parameter: how many impacts came before the first onset
    # (inference.missed_impacts). Each other numbering is screened by a Laplace estimate of
    # its evidence while the models are sampled; its evidence is then importance sampled
    # from the screen, and it is fitted only where that fails its diagnostic and the screen
    # does not put it far below the main fit's.
    numbered = (forward_model(config.model).needs_stick and settings.evidence != "none"
                and settings.missed_first > 0)
    # The numberings weighed: 0 … missed_first impacts missed, and as many as the source says;
    # and, where the onsets after the first still make a roll, the first onset a stray sound.
    highest = max(settings.missed_first, fitted.numbered_from)
    # (A later pass weighs it again from the first pass's screen, so that its probability is
    # given.) ``missed_first = 0`` imposes the source's numbering, the first onset's being a
    # bounce too.
    stray_weighed = (stray and settings.evidence != "none" and settings.missed_first > 0
                     and len(fitted.data.times) > MIN_ONSETS
                     and (first_pass or STRAY in numberings.screens))
    weighed = [*(range(highest + 1) if numbered else ()), *((STRAY,) if stray_weighed else ())]
    if weighed:
        weighed = sorted({*weighed, numbered_from})
    renumbered = {
        missed: LogPosterior.build(config, config.model, shifted(fitted.data, missed),
                                   settings.noise, settings.nu)
        for missed in weighed
        if missed != numbered_from and missed not in numberings.log_z}
    # ln Z of "the first onset is a stray sound" is that of the onsets after it times the stray
    # onset's own density, its level's likelihood ratio included
    # (missed_impacts.stray_log_density).
    own_density = ({STRAY: stray_log_density(fitted.data, fitted.onsets.amplitude)}
                   if stray_weighed else {})
    evidence_settings = replace(settings, sampler=replace(
        settings.sampler, target_ess=min(settings.sampler.target_ess, EVIDENCE_ONLY_ESS)))
    screens, screen_evidences = numberings.screens, numberings.screen_evidences

    def screen_numberings(between: Callable[[], None] | None = None) -> None:
        """Screen each other numbering (and in the first pass the fitted one too, so that a
        roll that begins late is refitted before its misnumbered fits end: they are slow, as
        a model that fits badly is); then :func:`check_screens`. ``between`` is called
        before each screen (the fits that are back are taken in, so that none waits for the
        screens: the main model's figures start as soon as its fit is back)."""
        begun = time.perf_counter()
        targets = dict(renumbered)
        if first_pass and renumbered:
            targets[numbered_from] = posteriors[config.model]
        for missed, log_posterior in targets.items():
            if missed in screens:  # screened in the first pass
                continue
            if between is not None:
                started_between = time.perf_counter()
                between()
                begun += time.perf_counter() - started_between  # not the screens' time
            found = screen(log_posterior, seeds[config.model])
            sample = importance_sample(log_posterior, found, seeds[config.model])
            extra = own_density.get(missed, 0.0)
            screens[missed] = replace(found, log_z=found.log_z + extra)
            screen_evidences[missed] = None
            if sample is not None:
                numberings.samples[missed] = sample  # for the average over the numberings
                screen_evidences[missed] = replace(sample.evidence,
                                                   log_z=sample.evidence.log_z + extra)
        if renumbered:  # while the models are sampled: part of "sampling", shown apart
            seconds["missed_first_screen"] = (seconds.get("missed_first_screen", 0.0)
                                              + time.perf_counter() - begun)
        check_screens()

    def check_screens() -> None:
        """In the first pass: stop at once for another numbering that the screens show is
        the likelier (``Numberings.early_renumbering``)."""
        if not (first_pass and renumbered):
            return
        likeliest = numberings.early_renumbering(numbered_from)
        if likeliest is not None:
            settled = sorted(numberings.log_z)
            found = missed_probabilities([numberings.log_z[m] for m in settled])
            raise _Renumber(likeliest, "by their screens", found[settled.index(likeliest)])

    def numberings_to_fit(bar) -> list[int]:
        """Once the main fit is back: the numberings that need a fit. Not those whose
        evidence importance sampling from their screen gives to its own diagnostic's
        satisfaction, nor those the main fit's evidence rules out by the screen alone (they
        keep their screened ln Z, and their probability is given as a bound)."""
        main_log_z = fits[config.model].evidence.log_z
        wanted = []
        for missed in renumbered:
            found, evidence = screens[missed], screen_evidences[missed]
            if evidence is not None and evidence.trusted:
                numberings.log_z[missed] = evidence.log_z
                bar.advance(note=f"{missed} missed: from its screen")
                continue
            if not needs_fit(found.log_z, main_log_z):
                numberings.log_z[missed] = found.log_z
                numberings.screened_out.add(missed)
                bar.advance(note=f"{missed} missed: screened out")
                continue
            wanted.append(missed)
        return wanted

    def keep_evidence(missed: int, output: tuple) -> None:
        chain, evidence = output[0], output[1]
        numberings.fitted[missed] = (renumbered[missed], chain.samples)  # for the average
        numberings.log_z[missed] = (-math.inf if evidence is None
                                    else evidence.log_z + own_density.get(missed, 0.0))

    def renumbered_fit(missed: int) -> tuple:
        return _fit, renumbered[missed], evidence_settings, seeds[config.model]

    def numbering_draws(mixed: dict[int, float]) -> dict[int, dict[str, np.ndarray]]:
        """The main model's draws of each numbering in ``mixed`` (quantity key → array): the
        main fit's; a numbering's own fit's (of this pass or the first); else the importance
        sample its evidence came from, which passed its diagnostic, resampled by its
        weights; any other is sampled now."""
        rng = np.random.default_rng(seeds[config.model])
        draws = {**numberings.draws, numbered_from: _variables(every_draw[config.model])}
        unsampled = {}
        for m in mixed:
            if m in draws:
                continue
            if m in numberings.fitted:
                log_posterior, samples = numberings.fitted[m]
                draws[m] = parameter_draws(log_posterior, samples, rng)[0]
                continue
            log_posterior = LogPosterior.build(config, config.model, shifted(fitted.data, m),
                                               settings.noise, settings.nu)
            sample = numberings.samples.get(m)
            if sample is not None and sample.evidence.trusted:
                draws[m] = parameter_draws(log_posterior,
                                           sample.resampled(RESAMPLED, rng)[None], rng)[0]
            else:
                unsampled[m] = log_posterior
        if unsampled:
            say(f"{config.model}: sampling the first onset numbered as impact "
                f"{', '.join(map(str, unsampled))}, for the average over the numberings")
            draws.update(_sampled_draws(unsampled, replace(evidence_settings, evidence="none"),
                                        seeds[config.model], workers))
        return draws

    def probabilities() -> dict[int, float]:
        """P(m) for every numbering weighed, once each one's ln Z is known (else {})."""
        main = fits.get(config.model)
        if not weighed or main is None or main.evidence is None:
            return {}
        log_z = {**numberings.log_z, numbered_from: main.evidence.log_z}
        if any(m not in log_z for m in weighed):
            return {}
        return dict(zip(weighed, missed_probabilities([log_z[m] for m in weighed]),
                        strict=True))

    def check_numbering() -> None:
        """In the first pass: stop for another numbering as soon as it is clearly
        preferred."""
        found = probabilities() if first_pass else {}
        likeliest = renumbering(found, numbered_from) if found else None
        if likeliest is not None:
            numberings.log_z[numbered_from] = fits[config.model].evidence.log_z
            numberings.draws[numbered_from] = _variables(every_draw[config.model])
            raise _Renumber(likeliest, f"P = {found[likeliest]:.3g} against "
                                       f"{found[numbered_from]:.2g}", found[likeliest])

    # One bar for every fit: the models, and the numberings screened or fitted.
    with reporter.bar(len(models) + len(renumbered), "sampling", "fit") as bar:
        if workers == 1:
            screen_numberings()
            for model in models:
                output = _fit(posteriors[model], settings, seeds[model])
                if not fits and first_pass:
                    _while_sampling(listener, onsets, recording)
                finish(model, output)
                say(f"{model}: done")
                bar.advance(note=model)
                if model == config.model and renumbered:
                    for missed in numberings_to_fit(bar):
                        function, *arguments = renumbered_fit(missed)
                        keep_evidence(missed, function(*arguments))
                        bar.advance(note=f"{missed} missed")
                    check_numbering()
        else:
            # emcee before the workers fork, so that they share it; the figures' libraries
            # and so on after, while the workers sample.
            importlib.import_module("drumroll.inference.ensemble")
            with process_pool(workers) as pool:
                pending = {pool.submit(_fit, posteriors[m], settings, seeds[m]): m
                           for m in models}
                if first_pass:
                    _while_sampling(listener, onsets, recording)
                screened = False

                def idle() -> int:
                    """The processes without a fit to run (they share LOO's terms)."""
                    return max(0, workers - sum(not f.done() for f in pending))

                def take(done) -> None:
                    """Take in the fits that are back; the main model's numberings are
                    fitted once it and every screen are back."""
                    for future in done:
                        task = pending.pop(future)
                        if isinstance(task, int):
                            keep_evidence(task, future.result())
                            bar.advance(note=f"{task} missed")
                            check_numbering()
                            continue
                        finish(task, future.result(), executor=pool, idle=idle)
                        say(f"{task}: done")
                        bar.advance(note=task)
                        if task == config.model and screened:
                            fit_numberings()

                def fit_numberings() -> None:
                    if renumbered:
                        pending.update({pool.submit(*renumbered_fit(missed)): missed
                                        for missed in numberings_to_fit(bar)})
                        check_numbering()

                screen_numberings(
                    between=lambda: take(wait(pending, timeout=0,
                                              return_when=FIRST_COMPLETED)[0]))
                screened = True
                if config.model in fits:  # back while the screens were made
                    fit_numberings()
                while pending:
                    take(wait(pending, return_when=FIRST_COMPLETED)[0])
    fits = {model: fits[model] for model in models}  # in the config's order
    seconds["sampling"] = time.perf_counter() - started - post_seconds

    from drumroll.inference.comparison import compare_models

    started = time.perf_counter()
    evidences = {m: f.evidence for m, f in fits.items() if f.evidence is not None}
    rows, preferred, verdict, loos = compare_models(
        {m: every_draw[m] for m in models}, config.model, evidences, loos,
        inadequate=[m for m, a in checked.items() if a.adequate is False],
        priors={m: f.log_posterior.space.priors for m, f in fits.items()})
    averaged = None
    if len(fits) > 1:  # one α for a table: the models stacked by their LOO predictions
        from drumroll.inference.model_average import model_average, stacking_weights

        weights = stacking_weights({m: loos[m].pointwise for m in fits})
        averaged = model_average({m: d.posterior for m, d in every_draw.items()}, weights,
                                 settings.hdi_prob, seed=settings.sampler.seed)
    seconds["comparison"] = time.perf_counter() - started + post_seconds
    main = fits[config.model]
    parameters = main.stats
    found = probabilities()
    missed_first = (tuple(found[m] for m in range(highest + 1)) if found and numbered else ())
    stray_first = found.get(STRAY, fitted.dropped_stray)
    numbering_averaged = None
    mixed = mixed_numberings(found)
    if mixed:  # no numbering clearly preferred: the honest posterior mixes them
        started = time.perf_counter()
        numbering_averaged = numbering_average(
            numbering_draws(mixed), mixed, numbered_from, settings.hdi_prob,
            seed=settings.sampler.seed)
        seconds["numbering_average"] = time.perf_counter() - started
    stray_warned = stray_warning(config.model, stray_first, fitted.dropped_stray is not None)
    model_diagnostics = {}
    evidence_entries = {}
    for m, fit in fits.items():
        model_diagnostics[m] = base_diagnostics[m]
        if fit.evidence is not None:
            evidence_entries[m], warning = evidence_summary(fit.evidence, fit.evidence_check)
            if warning:
                model_diagnostics[m] = replace(
                    model_diagnostics[m],
                    warnings=(*model_diagnostics[m].warnings, f"{m}: {warning}"))
        # (Given that the first onset is an impact: its being none has its own warning.)
        missed_warned = (missed_warning(m, _given_an_impact(missed_first), numbered_from)
                         if m == config.model else None)
        if missed_warned:
            model_diagnostics[m] = replace(
                model_diagnostics[m], warnings=(missed_warned, *model_diagnostics[m].warnings))
        if stray_warned and m == config.model:
            model_diagnostics[m] = replace(
                model_diagnostics[m], warnings=(stray_warned, *model_diagnostics[m].warnings))
        misfit = checked[m].misfit(m)
        if misfit:
            model_diagnostics[m] = replace(
                model_diagnostics[m], warnings=(misfit, *model_diagnostics[m].warnings))
    models_summary = {m: summaries[m] for m in models}
    summary = Summary(
        model=config.model, n_onsets=len(onsets), roll=fitted.roll, n_rolls=len(fitted.sizes),
        missing_bounces=tuple(data.missing),
        notes=(*fitted.notes, *_release_notes(main.log_posterior.space),
               *_predicted_prior_notes(config, {m: f.log_posterior.space
                                                for m, f in fits.items()}),
               *([missed_note(config.model, missed_first, numberings.screened_out,
                              numbered_from, fitted.numbered_from)]
                 if missed_first else [])),
        missed_first_impacts=missed_first, stray_first=stray_first,
        parameters=parameters,
        models=models_summary, observed_flights=observed[config.model],
        fixed={BY_NAME[name].key: BY_NAME[name].to_user(prior.value)
               for name, prior in main.log_posterior.space.priors.items() if prior.is_fixed},
        comparison=rows, preferred=preferred, verdict=verdict, model_average=averaged,
        numbering_average=numbering_averaged,
        diagnostics=model_diagnostics,
        evidence=evidence_entries, loo={m: loos[m].summary() for m in fits},
        onsets=tuple(Onset(float(t), float(s), int(k)) for t, s, k in zip(
            onsets.time_s, onsets.sigma_s, data.bounces, strict=True)),
        config=config.raw, source=source,
        version=__version__,
        seconds={**seconds, **{f"{m}_{k}": v for m, f in fits.items()
                               for k, v in f.seconds.items()}})
    return Result(summary=summary, fits=fits, onsets=onsets, config=config,
                  source=recording, seconds=seconds, loos=loos)
