"""The config sections that steer estimation: ``[sampler]``, ``[likelihood]``, ``[report]``.

::

    [sampler]
    walkers = 128             # ensemble walkers (raised to 2 ndim + 2 when smaller)
    max_steps = 20000         # stop here even if not converged (a warning says so)
    target_ess = 1000         # bulk and tail ESS every reported quantity reaches
    max_r_hat = 1.01          # R-hat (walkers in 4 groups) every reported quantity stays under
    seed = 0                  # everything random in the run
    evidence = "auto"         # ln Z for Bayes factors: "auto" (importance sampling, nested
                              # sampling where its Pareto k fails), "nested" (dynesty
                              # always), false (none); true means "auto"
    live_points = 200         # dynesty live points
    workers = 2               # processes fitting models side by side (default: cores)

    [likelihood]
    noise = "gaussian"        # or "student-t" for recordings with a few bad onsets
    nu = 4                    # Student-t degrees of freedom: a number or a prior table

    [report]
    hdi_prob = 0.9            # credible-interval mass in tables and summary.json
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

from drumroll.config.loader import Config, register_section
from drumroll.config.priors_section import parse_prior
from drumroll.config.validate import boolean, check_keys, number, string
from drumroll.distributions import Distribution, Fixed
from drumroll.errors import ConfigError
from drumroll.inference.missed_impacts import MAX_MISSED
from drumroll.inference.posterior import NOISE_MODELS
from drumroll.inference.sampling import SamplerSettings
from drumroll.physics.contact import CONTACT_LAWS
from drumroll.quantities import QUANTITIES


@dataclass(frozen=True)
class EstimateSettings:
    """Everything ``estimate`` needs beyond the model and priors."""

    sampler: SamplerSettings = field(default_factory=SamplerSettings)
    evidence: str = "auto"
    live_points: int = 200
    workers: int = field(default_factory=lambda: os.cpu_count() or 1)
    noise: str = "gaussian"
    nu: Distribution = field(default_factory=lambda: Fixed(4.0))
    missed_first: int = MAX_MISSED
    contact: str = "constant"
    hdi_prob: float = 0.9


def _integer(value: Any, key: str, minimum: int) -> int:
    value = number(value, key, integer=True)
    if value < minimum:
        raise ConfigError(f"{key}: must be at least {minimum}, got {value}")
    return int(value)


def parse_sampler(section: dict[str, Any], where: str) -> dict[str, Any]:
    """The ``[sampler]`` section as keyword arguments (see the module docstring)."""
    check_keys(section, ("walkers", "max_steps", "seed", "evidence", "live_points", "workers",
                         "tau_multiple", "target_ess", "max_r_hat"), where)
    out: dict[str, Any] = {}
    if "walkers" in section:
        out["walkers"] = _integer(section["walkers"], f"{where}.walkers", 4)
    if "max_steps" in section:
        out["max_steps"] = _integer(section["max_steps"], f"{where}.max_steps", 100)
    if "seed" in section:
        out["seed"] = _integer(section["seed"], f"{where}.seed", 0)
    if "tau_multiple" in section:
        out["tau_multiple"] = float(number(section["tau_multiple"], f"{where}.tau_multiple",
                                           positive=True))
    if "target_ess" in section:
        out["target_ess"] = float(number(section["target_ess"], f"{where}.target_ess",
                                         positive=True))
    if "max_r_hat" in section:
        r_hat = float(number(section["max_r_hat"], f"{where}.max_r_hat"))
        if not r_hat > 1:
            raise ConfigError(f"{where}.max_r_hat: must be above 1, got {r_hat:g}")
        out["max_r_hat"] = r_hat
    if "evidence" in section:
        out["evidence"] = evidence_mode(section["evidence"], f"{where}.evidence")
    if "live_points" in section:
        out["live_points"] = _integer(section["live_points"], f"{where}.live_points", 20)
    if "workers" in section:
        out["workers"] = _integer(section["workers"], f"{where}.workers", 1)
    return out


def evidence_mode(value: Any, key: str) -> str:
    """``[sampler] evidence`` as one of :data:`EVIDENCE_MODES`: ``"auto"``, ``"nested"``,
    or ``false`` (``"none"``); ``true`` (older configs: nested sampling then) means
    ``"auto"``, which falls back to nested sampling wherever the cheap estimate fails its
    own diagnostic."""
    if isinstance(value, bool):
        return "auto" if boolean(value, key) else "none"
    if isinstance(value, str):
        return string(value, key, ("auto", "nested"))
    raise ConfigError(f'{key}: expected "auto", "nested", true or false, got {value!r}')


def parse_likelihood(section: dict[str, Any], where: str) -> dict[str, Any]:
    """The ``[likelihood]`` section: ``noise``, ``nu``, ``missed_first`` (the most
    impacts a stick model considers missed before the first onset:
    :mod:`~drumroll.inference.missed_impacts`) and ``contact`` (the contact time's law,
    :mod:`~drumroll.physics.contact`)."""
    check_keys(section, ("noise", "nu", "missed_first", "contact"), where)
    out: dict[str, Any] = {}
    if "contact" in section:
        out["contact"] = string(section["contact"], f"{where}.contact", CONTACT_LAWS)
    if "missed_first" in section:
        out["missed_first"] = _integer(section["missed_first"], f"{where}.missed_first", 0)
        if out["missed_first"] > MAX_MISSED:
            raise ConfigError(f"{where}.missed_first: at most {MAX_MISSED} (each may cost a fit of "
                              f"the model), got {out['missed_first']}")
    if "noise" in section:
        out["noise"] = string(section["noise"], f"{where}.noise", NOISE_MODELS)
    if "nu" in section:
        out["nu"] = parse_prior(section["nu"], QUANTITIES["nu"], f"{where}.nu")
    return out


def parse_report(section: dict[str, Any], where: str) -> dict[str, Any]:
    """The ``[report]`` section: ``hdi_prob``."""
    check_keys(section, ("hdi_prob",), where)
    out: dict[str, Any] = {}
    if "hdi_prob" in section:
        p = float(number(section["hdi_prob"], f"{where}.hdi_prob"))
        if not 0 < p < 1:
            raise ConfigError(f"{where}.hdi_prob: must lie strictly between 0 and 1, got {p:g}")
        out["hdi_prob"] = p
    return out


def estimate_settings(config: Config) -> EstimateSettings:
    """The config's ``[sampler]``, ``[likelihood]`` and ``[report]`` sections as
    :class:`EstimateSettings` (what a section leaves out takes its default)."""
    sampler = dict(config.section("sampler", {}))
    top = {k: sampler.pop(k) for k in ("evidence", "live_points", "workers") if k in sampler}
    return EstimateSettings(sampler=SamplerSettings(**sampler), **top,
                            **config.section("likelihood", {}), **config.section("report", {}))


register_section("sampler", parse_sampler)
register_section("likelihood", parse_likelihood)
register_section("report", parse_report)
