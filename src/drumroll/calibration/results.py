"""What ``drumroll calibrate`` found, as typed records (``calibration.json`` is
:meth:`CalibrationResult.to_json`; :meth:`~drumroll.inference.results.Record.from_json` reads
it back): the settings, every simulation's fits, and the statistics of each calibration
(:mod:`drumroll.inference.calibration`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

from drumroll.calibration.recording import Hearing
from drumroll.inference.calibration import QuantityCalibration
from drumroll.inference.results import Record

#: Onsets of a simulated roll unless asked otherwise: the longest roll the extractor finds
#: in the paper's bundled set-ups (table2_h80, the worked example: 16 onsets; the others
#: 10 to 15).
DEFAULT_ONSETS = 16
#: Posterior draws each truth is ranked among (L): ranks 0 … 99, a hundred values, which
#: 10 or 20 histogram bins divide evenly; well below the ESS of 1,000 the sampler reaches.
RANK_DRAWS = 99


@dataclass(frozen=True)
class CalibrationSettings(Record):
    """What was calibrated, and how.

    Attributes
    ----------
    model
        The config's main model.
    n
        Simulations.
    n_onsets
        Onsets per simulated roll.
    rank_draws
        L, the posterior draws each truth is ranked among.
    seed
        Seed every simulation's seeds derive from.
    audio
        Whether the rolls were also rendered and heard by the extractor.
    sound
        Whose sound they were rendered with: ``"config"`` (its ``[simulate]`` section) or
        ``"default"`` (``drumroll simulate``'s, the config having none).
    noise
        The config's ``[likelihood] noise``.
    sampler
        The sampler's settings (the config's ``[sampler]``, defaults filled in), the seed
        apart: each fit has its own.
    """

    model: str = ""
    n: int = 0
    n_onsets: int = DEFAULT_ONSETS
    rank_draws: int = RANK_DRAWS
    seed: int = 0
    audio: bool = False
    sound: str = "config"
    noise: str = "gaussian"
    sampler: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class FitRecord(Record):
    """One fit of one simulation: per quantity (by key, user's units) the truth's rank among
    the L draws, the posterior mean and sd (on every draw), and whether the central 50 % and
    90 % intervals held the truth; then how the sampler did."""

    n_onsets: int = 0
    rank: dict[str, int] = field(default_factory=dict)
    mean: dict[str, float] = field(default_factory=dict)
    sd: dict[str, float] = field(default_factory=dict)
    covered_50: dict[str, bool] = field(default_factory=dict)
    covered_90: dict[str, bool] = field(default_factory=dict)
    rank_draws: int = 0
    spacing: int = 1
    converged: bool = False
    r_hat_max: float | None = None
    ess_min: float | None = None
    n_steps: int = 0
    adequate: bool | None = None
    seconds: float = 0.0


@dataclass(frozen=True)
class DrawRecord(Record):
    """One simulation.

    Attributes
    ----------
    index
        Its number, 0 … n − 1 (its seeds derive from it and the run's seed).
    attempts
        Parameter points drawn until a roll was simulated and fitted.
    rejected
        Draws made again, by reason (:mod:`.roll`; the extractor hearing too little; the
        estimate refusing the onsets).
    truth
        The true value of every quantity (user's units): θ̃, what the model derives from it,
        and T0.
    onsets
        The fit of the simulated onsets.
    audio, hearing, audio_t0_s
        With ``audio``: the fit of the extractor's onsets, how it heard the roll, and the
        truth of that fit's T0 (the impact its first onset belongs to).
    seconds
        Wall time of the simulation and its fits.
    """

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "onsets": (FitRecord, "one"), "audio": (FitRecord, "one"), "hearing": (Hearing, "one")}

    index: int = 0
    attempts: int = 1
    rejected: dict[str, int] = field(default_factory=dict)
    truth: dict[str, float] = field(default_factory=dict)
    onsets: FitRecord = field(default_factory=FitRecord)
    audio: FitRecord | None = None
    hearing: Hearing | None = None
    audio_t0_s: float | None = None
    seconds: float = 0.0


@dataclass(frozen=True)
class LevelCalibration(Record):
    """The calibration of one level (the onsets, or the extractor's onsets).

    Attributes
    ----------
    level
        ``"onsets"`` or ``"audio"``.
    parameters
        Keys of the sampled parameters (T0 among them), in report order.
    derived
        Keys of the quantities derived from them (t_B, t_C, …).
    quantities
        Key → its :class:`~drumroll.inference.calibration.QuantityCalibration`.
    unconverged
        Fits that stopped at the step limit before meeting the ESS and R-hat targets.
    inadequate
        Fits whose residual checks said the model does not describe the onsets (the
        checks' own false-alarm rate, here, where the model is the truth).
    """

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "quantities": (QuantityCalibration, "dict")}

    level: str = "onsets"
    parameters: tuple[str, ...] = ()
    derived: tuple[str, ...] = ()
    quantities: dict[str, QuantityCalibration] = field(default_factory=dict)
    unconverged: int = 0
    inadequate: int = 0

    @property
    def passed(self) -> bool:
        """Whether every parameter passed (:attr:`QuantityCalibration.passed`)."""
        return all(self.quantities[key].passed for key in self.parameters)

    def failed(self, keys: tuple[str, ...] | None = None) -> list[str]:
        """The quantities among ``keys`` (default: the parameters) that did not pass."""
        keys = self.parameters if keys is None else keys
        return [key for key in keys if not self.quantities[key].passed]


@dataclass(frozen=True)
class CalibrationResult(Record):
    """Everything ``drumroll calibrate`` found (``calibration.json`` is its :meth:`to_json`).

    Attributes
    ----------
    settings
        What was calibrated, and how.
    onsets
        The calibration of the fits of the simulated onsets.
    audio
        With ``settings.audio``: the calibration of the fits of the extractor's onsets.
    draws
        Every simulation: truths, ranks, means, sds, coverage, sampler diagnostics.
    prior_variance
        Each quantity's variance under the prior (truncated to the points the physics
        allows): contraction's reference. T0's is that of its flat prior's window.
    attempts, rejected
        Parameter points drawn over all simulations, and those drawn again by reason.
    config, config_path
        The config as read, and its file.
    versions
        drumroll's and its numerical libraries' versions.
    seconds
        Wall time of the run.
    cpu_seconds
        The simulations' own time summed (what one process would take).
    """

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "settings": (CalibrationSettings, "one"), "onsets": (LevelCalibration, "one"),
        "audio": (LevelCalibration, "one"), "draws": (DrawRecord, "tuple")}

    settings: CalibrationSettings = field(default_factory=CalibrationSettings)
    onsets: LevelCalibration = field(default_factory=LevelCalibration)
    audio: LevelCalibration | None = None
    draws: tuple[DrawRecord, ...] = ()
    prior_variance: dict[str, float] = field(default_factory=dict)
    attempts: int = 0
    rejected: dict[str, int] = field(default_factory=dict)
    config: dict[str, Any] = field(default_factory=dict)
    config_path: str | None = None
    versions: dict[str, str] = field(default_factory=dict)
    seconds: float = 0.0
    cpu_seconds: float = 0.0

    def level(self, name: str) -> LevelCalibration:
        """The calibration ``name`` (``"onsets"`` or ``"audio"``)."""
        level = self.audio if name == "audio" else self.onsets
        if level is None:
            raise KeyError(f"no {name} calibration in this result")
        return level

    @property
    def levels(self) -> dict[str, LevelCalibration]:
        """The calibrations made, by name."""
        return {name: level for name, level in (("onsets", self.onsets),
                                                 ("audio", self.audio)) if level is not None}

    @property
    def passed(self) -> bool:
        """Whether every parameter of the onset-level calibration passed."""
        return self.onsets.passed
