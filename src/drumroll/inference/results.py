"""What an estimate found, as typed records with one ``to_json`` each: ``summary.json``.

:class:`Summary` is the contract between the pipeline and everything that shows or keeps a
result (``summary.json``, ``report.md``, the terminal, the table's cache and formats, joint
fits): they read its attributes, and :meth:`Record.from_json` reads a saved one back.
Numbers are in the user's units (the quantity registry's keys and units); NaN and infinities
are written as ``null``.

Sign convention of the comparison (one, everywhere): :class:`ComparisonRow` differences are
**main model − other model**, so a positive ``elpd_loo_diff`` or ``log_bayes_factor`` favours
the main model.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar


def json_number(value: Any) -> float | None:
    """A float for JSON: None for NaN, infinities and None."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _to_json(value: Any) -> Any:
    if isinstance(value, Record):
        return value.to_json()
    if isinstance(value, Mapping):
        return {str(k): _to_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_to_json(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, str | int):
        return value
    if isinstance(value, float):
        return json_number(value)
    if hasattr(value, "item"):  # a numpy scalar
        return _to_json(value.item())
    return value


@dataclass(frozen=True)
class Record:
    """A result record: its fields are its JSON keys (:meth:`to_json`, :meth:`from_json`).

    Subclasses name the fields that hold other records in :attr:`nested`: field → (record
    class, ``"one"``, ``"tuple"`` of them or ``"dict"`` of them by name).
    """

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {}

    def to_json(self) -> dict[str, Any]:
        """The record as JSON-ready Python (dicts, lists, numbers, text, None)."""
        return {f.name: _to_json(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]):
        """A record from :meth:`to_json`'s output (unknown keys are ignored, missing ones take
        their defaults)."""
        values = {}
        for f in dataclasses.fields(cls):
            if f.name not in data:
                continue
            value = data[f.name]
            kind, container = cls.nested.get(f.name, (None, ""))
            if kind is not None and value is not None:
                if container == "dict":
                    value = {k: kind.from_json(v) for k, v in value.items()}
                elif container == "tuple":
                    value = tuple(kind.from_json(v) for v in value)
                else:
                    value = kind.from_json(value)
            elif isinstance(value, list):
                value = tuple(value)
            values[f.name] = value
        return cls(**values)


@dataclass(frozen=True)
class ParameterSummary(Record):
    """One posterior quantity: mean, sd, median, highest-density interval, R-hat, ESS.

    ESS treats the walkers as chains and R-hat groups of walkers
    (:mod:`~drumroll.inference.convergence`): the numbers the sampler's stopping rule checked.
    """

    mean: float | None = None
    sd: float | None = None
    median: float | None = None
    hdi_low: float | None = None
    hdi_high: float | None = None
    hdi_prob: float = 0.9
    r_hat: float | None = None
    ess_bulk: float | None = None
    ess_tail: float | None = None
    #: The posterior probability that the quantity is exactly 0, where its prior gives 0 a
    #: probability of its own (an effect that may be absent: the default contact time).
    probability_zero: float | None = None


@dataclass(frozen=True)
class Diagnostics(Record):
    """How one model's sampler run went, and what the user should know (``warnings``)."""

    converged: bool = False
    n_steps: int = 0
    burn: int = 0
    thin: int = 1
    walkers: int = 0
    draws: int = 0
    tau_max: float | None = None
    acceptance: float | None = None
    r_hat_max: float | None = None
    ess_bulk_min: float | None = None
    ess_tail_min: float | None = None
    checks: int = 0
    target_ess: float = 1000.0
    max_r_hat: float = 1.01
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True)
class EvidenceSummary(Record):
    """ln Z of one model, by which estimator, and importance sampling's own check.

    ``method`` is ``"importance"`` or ``"nested"``; ``pareto_k`` and ``importance_ess`` are
    importance sampling's diagnostics, ``fallback`` why nested sampling was used instead
    (None when it was not, or was asked for), ``importance_log_z`` importance sampling's
    estimate when nested sampling gave ``log_z``.
    """

    log_z: float | None = None
    log_z_err: float | None = None
    method: str = "importance"
    n_calls: int = 0
    fallback: str | None = None
    pareto_k: float | None = None
    importance_ess: float | None = None
    importance_log_z: float | None = None
    importance_log_z_err: float | None = None


@dataclass(frozen=True)
class LooSummary(Record):
    """PSIS-LOO of one model: the expected log predictive density of the onsets, its
    standard error, and the onsets (bounce numbers) where the approximation is unreliable
    (Pareto k > 0.7)."""

    elpd_loo: float | None = None
    elpd_loo_se: float | None = None
    pareto_k_bad: tuple[int, ...] = ()


@dataclass(frozen=True)
class ComparisonRow(Record):
    """The main model against one other: differences are **main − other** (positive favours
    the main model). ``pareto_k_bad`` lists the other model's onsets (bounce numbers) where
    PSIS-LOO is unreliable."""

    model: str = ""
    elpd_loo_diff: float | None = None
    elpd_loo_diff_se: float | None = None
    elpd_loo: float | None = None
    elpd_loo_se: float | None = None
    pareto_k_bad: tuple[int, ...] = ()
    log_bayes_factor: float | None = None
    log_bayes_factor_err: float | None = None
    #: ln B with the priors of the parameters only one model samples half / twice as wide
    #: (:mod:`~drumroll.inference.prior_sensitivity`), and whether it then moves by > 1 nat.
    log_bayes_factor_half_width: float | None = None
    log_bayes_factor_double_width: float | None = None
    prior_dominated: bool | None = None


@dataclass(frozen=True)
class ModelAverage(Record):
    """α and t_B averaged over the fitted models with stacking weights
    (:mod:`~drumroll.inference.model_average`): one number for a table when the comparison
    cannot pick a model, or when the models' α differ by more than their error bars.
    ``parameters``' intervals are highest-density intervals of the weighted mixture of the
    models' draws; R-hat and ESS are not defined for a mixture (None)."""

    weights: dict[str, float] = field(default_factory=dict)
    parameters: dict[str, ParameterSummary] = field(default_factory=dict)
    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "parameters": (ParameterSummary, "dict")}


#: The key of "the first onset is no impact of the roll" among a numbering average's
#: ``probabilities`` (the others are the impacts missed: "0", "1", …).
STRAY_KEY = "stray"


@dataclass(frozen=True)
class NumberingAverage(Record):
    """The main model's quantities averaged over the first onset's numberings
    (:func:`~drumroll.inference.missed_impacts.numbering_average`): where no numbering is
    clearly preferred, every number of one numbering's fit holds only if that numbering is
    the right one, and the honest posterior is the mixture of the numberings' posteriors
    weighted by their probabilities. ``probabilities`` maps impacts missed ("0", "1", …) to
    the weight of that numbering in the mixture, "stray" that of the first onset's being no
    impact of the roll (those of probability 0.01 or more, renormalised); ``fitted`` is the
    numbering the fits and figures use. Intervals are highest-density intervals of the
    mixture (R-hat and ESS: None)."""

    fitted: str = "0"
    probabilities: dict[str, float] = field(default_factory=dict)
    parameters: dict[str, ParameterSummary] = field(default_factory=dict)
    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "parameters": (ParameterSummary, "dict")}


@dataclass(frozen=True)
class FlightSeries(Record):
    """One model's flights T_1 … T_K (s): posterior median and central band (probability
    ``prob``) of the noise-free flight times, entry k − 1 being flight k."""

    median: tuple[float, ...] = ()
    low: tuple[float, ...] = ()
    high: tuple[float, ...] = ()
    prob: float = 0.9


@dataclass(frozen=True)
class ObservedFlights(Record):
    """The observed flight times T_1 … T_K (s) and their 1σ errors (s), entry k − 1 being
    flight k; None where flight k was not observed (a bounce on either side unheard). The
    error combines its two onsets, each with the main model's posterior median jitter and the
    extractor's own sigma in quadrature."""

    time_s: tuple[float | None, ...] = ()
    err_s: tuple[float | None, ...] = ()


@dataclass(frozen=True)
class OnsetResiduals(Record):
    """One model's onset residuals (s), each relative to the posterior median replicated
    onset: the observed onsets' (``residual``), the central band (probability ``prob``) of
    replicated onsets, noise included (``low``, ``high``), and of the noise-free model
    (``model_low``, ``model_high``; empty when not known); with each onset's bounce number
    and the extractor's sigma."""

    bounce: tuple[int, ...] = ()
    residual: tuple[float, ...] = ()
    sigma: tuple[float, ...] = ()
    low: tuple[float, ...] = ()
    high: tuple[float, ...] = ()
    model_low: tuple[float, ...] = ()
    model_high: tuple[float, ...] = ()
    prob: float = 0.9


@dataclass(frozen=True)
class AdequacyCheck(Record):
    """One posterior predictive check of the residuals (:mod:`drumroll.inference.adequacy`):
    the statistic's posterior mean for the observed onsets and for replicated ones, and the
    p-value."""

    observed: float | None = None
    replicated: float | None = None
    p_value: float | None = None


@dataclass(frozen=True)
class Adequacy(Record):
    """Whether a model describes the onsets: its checks by statistic name, and ``adequate``
    (every p-value at least ``level``; None when the roll is too short to check)."""

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "checks": (AdequacyCheck, "dict")}

    checks: dict[str, AdequacyCheck] = field(default_factory=dict)
    adequate: bool | None = None
    level: float = 0.01

    def misfit(self, model: str) -> str | None:
        """One sentence saying that ``model`` does not describe the onsets, and how it shows;
        None when it does (or could not be checked)."""
        if self.adequate is not False:
            return None
        shown = []
        lag = self.checks.get("lag1_autocorrelation")
        if lag is not None and lag.p_value is not None and lag.p_value < self.level:
            shown.append(f"neighbouring residuals correlate at {lag.observed:.2f} where the "
                         f"model's own noise gives {lag.replicated:.2f} "
                         f"({p_value_text(lag.p_value)})")
        runs = self.checks.get("sign_runs")
        if runs is not None and runs.p_value is not None and runs.p_value < self.level:
            shown.append(f"they change sign in {runs.observed:.0f} runs where the model's "
                         f"noise gives {runs.replicated:.0f} ({p_value_text(runs.p_value)})")
        walk = self.checks.get("scatter_walk")
        if walk is not None and walk.p_value is not None and walk.p_value < self.level:
            shown.append(f"they drift from the fit as a restitution that scatters from bounce "
                         f"to bounce moves onsets, {walk.observed:.1f} times what independent "
                         f"noise puts there, where the model's own noise gives "
                         f"{walk.replicated:.1f} ({p_value_text(walk.p_value)})")
        return (f"{model} does not describe these onsets: {'; '.join(shown)}. Its error bars "
                "describe the model, not the bouncer (a restitution that changes with speed "
                "or from bounce to bounce, or a mis-numbered bounce, leaves this pattern)")


def p_value_text(value: float) -> str:
    """A p-value in words: ``p = 0.004``, or ``p < 0.001``."""
    return "p < 0.001" if value < 0.001 else f"p = {value:.3f}"


@dataclass(frozen=True)
class ModelSummary(Record):
    """One fitted model: its posterior summaries by quantity key, its flights, its onset
    residuals, and whether it describes the onsets (:class:`Adequacy`)."""

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "parameters": (ParameterSummary, "dict"), "flights": (FlightSeries, "one"),
        "residuals": (OnsetResiduals, "one"), "adequacy": (Adequacy, "one")}

    parameters: dict[str, ParameterSummary] = field(default_factory=dict)
    flights: FlightSeries = field(default_factory=FlightSeries)
    residuals: OnsetResiduals = field(default_factory=OnsetResiduals)
    adequacy: Adequacy | None = None


@dataclass(frozen=True)
class Onset(Record):
    """One fitted onset: time and timing uncertainty (s), bounce number."""

    time_s: float = 0.0
    sigma_s: float = 0.0
    bounce: int = 0


@dataclass(frozen=True)
class Summary(Record):
    """Everything ``estimate`` reports (``summary.json``).

    Attributes
    ----------
    model
        The main model.
    n_onsets, roll, n_rolls, missing_bounces, notes
        The fitted roll: how many onsets, which roll of how many, the bounces not heard, and
        what the user should read before the numbers.
    missed_first_impacts
        P(m impacts came before the first onset | onsets), m = 0, 1, 2, under a stick model
        (:mod:`~drumroll.inference.missed_impacts`); empty otherwise.
    stray_first
        P(the source's first onset is no impact of the roll | onsets): a tap or another sound
        before the roll taken for its first bounce (:data:`~.missed_impacts.STRAY`); where it
        was the likelier, the fit starts from the onset after it and a note says so. None
        where it was not weighed (no evidence, too few onsets).
    parameters
        The main model's posterior summaries, by quantity key (those of ``models[model]``).
    numbering_average
        The main model's quantities averaged over the first onset's numberings, where more
        than one has a probability of 0.01 or more (:class:`NumberingAverage`); else None.
    models
        Every fitted model's summaries and flights, main model first.
    observed_flights
        The flights the onsets show, with errors.
    fixed
        The main model's fixed parameters, by key, in the user's units.
    comparison
        One row per other model (main − other).
    preferred, verdict
        The model the comparison prefers (None: the data cannot tell), and why, in words.
    diagnostics, evidence, loo
        Per model.
    onsets
        The fitted onsets.
    config, source, version, seconds
        The configuration used, the recording, drumroll's version, seconds by stage.
    """

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "parameters": (ParameterSummary, "dict"), "models": (ModelSummary, "dict"),
        "observed_flights": (ObservedFlights, "one"), "comparison": (ComparisonRow, "tuple"),
        "diagnostics": (Diagnostics, "dict"), "evidence": (EvidenceSummary, "dict"),
        "loo": (LooSummary, "dict"), "onsets": (Onset, "tuple"),
        "model_average": (ModelAverage, "one"),
        "numbering_average": (NumberingAverage, "one")}

    model: str = ""
    n_onsets: int = 0
    roll: int = 0
    n_rolls: int = 1
    missing_bounces: tuple[int, ...] = ()
    notes: tuple[str, ...] = ()
    missed_first_impacts: tuple[float, ...] = ()
    stray_first: float | None = None
    parameters: dict[str, ParameterSummary] = field(default_factory=dict)
    models: dict[str, ModelSummary] = field(default_factory=dict)
    observed_flights: ObservedFlights = field(default_factory=ObservedFlights)
    fixed: dict[str, float] = field(default_factory=dict)
    comparison: tuple[ComparisonRow, ...] = ()
    preferred: str | None = None
    verdict: str = ""
    model_average: ModelAverage | None = None
    numbering_average: NumberingAverage | None = None
    diagnostics: dict[str, Diagnostics] = field(default_factory=dict)
    evidence: dict[str, EvidenceSummary] = field(default_factory=dict)
    loo: dict[str, LooSummary] = field(default_factory=dict)
    onsets: tuple[Onset, ...] = ()
    config: dict[str, Any] = field(default_factory=dict)
    source: str | None = None
    version: str = ""
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def misfit(self) -> str | None:
        """The main model's misfit (see :meth:`Adequacy.misfit`): said before any number."""
        fitted = self.models.get(self.model)
        return None if fitted is None or fitted.adequacy is None else \
            fitted.adequacy.misfit(self.model)

    @property
    def warnings(self) -> list[str]:
        """Every model's diagnostic warnings, main model first."""
        return [w for d in self.diagnostics.values() for w in d.warnings]
