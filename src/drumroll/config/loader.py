"""Reading and validating a config file.

The format (lengths in mm, times in s, speeds in m/s, as in the paper's tables)::

    model = "pendulum"            # "powerlaw" | "small-angle" | "pendulum", each optionally
                                  # "/speed": a restitution that depends on the impact speed
    compare = ["small-angle"]     # models to compare against
    gravity_m_s2 = 9.81           # optional

    [stick]                       # needed by small-angle and pendulum
    shape = "cylinder-cone"       # or "thin-rod"
    length_mm = 348               # l1 (thin-rod: the whole length L)
    tip_mm = 60                   # l2 (cylinder-cone only)
    radius_mm = 7.5               # (cylinder-cone only)

    [priors]                      # a number fixes a parameter; a table gives a distribution
    alpha = { dist = "uniform", low = 0.5, high = 1.0 }
    pivot_mm = { dist = "normal", mu = 131, sigma = 2 }
    ...

Stick dimensions may also be distributions (``length_mm = { dist = "normal", mu = 348,
sigma = 1 }``), which ``predict`` propagates. The other sections (:data:`SECTIONS`:
``[simulate]``, ``[sampler]``, ``[likelihood]``, ``[report]``) belong to the stages that read
them: each stage registers its section's parser with :func:`register_section` when imported,
so the config never imports the stages that use it.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drumroll.config.priors_section import parse_prior
from drumroll.config.validate import check_keys, number, string, table
from drumroll.distributions import Distribution, Fixed
from drumroll.errors import ConfigError, UnknownKey
from drumroll.physics import MODELS, STANDARD_GRAVITY, STICK_SHAPES
from drumroll.physics.geometry import StickGeometry
from drumroll.physics.models import canonical_name, parameter_keys
from drumroll.physics.release import tip_strikes_first
from drumroll.quantities import DEFAULT_PRIORS, DEFAULT_VALUES, PARAMETERS, STICK_DIMENSIONS

#: The parameter a [stick] section predicts: left out, the power law's t_B prior is the
#: geometry's prior predictive rather than a flat range whose width would decide a Bayes factor.
GEOMETRY_PREDICTS = "t_b"

#: The sections of the file format read by later stages (the simulator, the sampler, …).
SECTIONS: tuple[str, ...] = ("simulate", "sampler", "likelihood", "report")

#: A section's parser: takes (table, where) and returns the parsed section, raising
#: ConfigError with the key's path on bad input.
SectionParser = Callable[[dict[str, Any], str], Any]

_SECTION_PARSERS: dict[str, SectionParser] = {}


def register_section(name: str, parser: SectionParser) -> None:
    """Register the parser of the section ``name`` (one of :data:`SECTIONS`).

    The stage that reads a section calls this when it is imported. A config parsed before
    then keeps the section as read, and parses it when :meth:`Config.section` is first asked
    for it.
    """
    if name not in SECTIONS:
        raise ValueError(f"unknown config section {name!r} (expected one of {SECTIONS})")
    _SECTION_PARSERS[name] = parser

_TOP_LEVEL = ("model", "compare", "gravity_m_s2", "stick", "priors")


@dataclass(frozen=True)
class StickSpec:
    """The ``[stick]`` section: a shape and dimensions that may be uncertain (SI units)."""

    shape: str
    length: Distribution
    tip: Distribution = field(default_factory=lambda: Fixed(0.0))
    radius: Distribution = field(default_factory=lambda: Fixed(0.0))

    def nominal(self) -> StickGeometry:
        """The stick at the median of each dimension."""
        return StickGeometry(self.shape, self.length.median(), self.tip.median(),
                             self.radius.median())

    def sample(self, rng: np.random.Generator, size: int) -> StickGeometry:
        """``size`` sticks with dimensions drawn from their priors (arrays of length size)."""
        return StickGeometry(self.shape, self.length.sample(rng, size),
                             self.tip.sample(rng, size), self.radius.sample(rng, size))


@dataclass(frozen=True)
class Config:
    """A validated config, in SI units.

    Attributes
    ----------
    model
        The main forward model.
    compare
        Models to compare the main one against (never contains ``model``).
    priors
        Distribution per parameter by internal (SI) name, e.g. ``priors["pivot"]``; parameters the
        config leaves out take :data:`~drumroll.quantities.DEFAULT_VALUES`.
    stick
        The stick, or None when no model needs one.
    gravity
        g (m/s²).
    sections
        The later stages' sections (:data:`SECTIONS`) parsed so far: those whose parser was
        registered when the file was read; :meth:`section` parses the others when asked.
    raw
        The file's content as read, for reports.
    path
        Where it was read from, if anywhere.
    """

    model: str
    compare: tuple[str, ...]
    priors: dict[str, Distribution]
    stick: StickSpec | None
    gravity: float = STANDARD_GRAVITY
    sections: dict[str, Any] = field(default_factory=dict)
    raw: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    @property
    def models(self) -> tuple[str, ...]:
        """The main model followed by the compared ones."""
        return (self.model, *self.compare)

    def section(self, name: str, default: Any = None) -> Any:
        """The parsed section ``name`` (``default`` when the file has none).

        Raises
        ------
        ConfigError
            The section is malformed.
        """
        if name not in self.sections and name in self.raw:
            self.sections[name] = _parse_section(self.raw[name], name)
        return self.sections.get(name, default)

    def has_prior(self, key: str) -> bool:
        """Whether the file gave ``key`` (a config name such as ``"t_b"``) a value or prior."""
        return key in self.raw.get("priors", {})


def load_config(path: str | Path) -> Config:
    """Read and validate the config file at ``path``.

    Raises
    ------
    ConfigError
        One line naming the file and the key: malformed TOML (with line and column), unknown
        keys (with a suggestion), wrong types, empty or inverted ranges, values outside their
        physical range, a pivot past the centre of mass, a height the tip cannot reach.
    """
    path = Path(path)
    raw = read_toml(path, "config file")
    try:
        return parse_config(raw, path=path)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def read_toml(path: Path, what: str, prefix: str = "") -> dict[str, Any]:
    """The TOML document at ``path``, or a one-line :class:`ConfigError` saying why not.

    Parameters
    ----------
    path
        The file.
    what
        What the file should be, for messages ("config file", "runs file").
    prefix
        Put before the message (e.g. the key that named the file).
    """
    lead = f"{prefix}{path}"
    try:
        # utf-8-sig: the byte-order mark Windows editors put first is no TOML statement.
        return tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    except FileNotFoundError:
        raise ConfigError(f"{lead}: no such {what}") from None
    except IsADirectoryError:
        raise ConfigError(f"{lead}: is a directory, expected a TOML {what}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{lead}: not UTF-8 text at byte {exc.start} (TOML is UTF-8: save "
                          "the file as UTF-8)") from None
    except OSError as exc:
        raise ConfigError(f"{lead}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{lead}: invalid TOML: {exc}") from None


def parse_config(raw: Mapping[str, Any], path: Path | None = None) -> Config:
    """Validate an already-parsed TOML document (see :func:`load_config`)."""
    raw = dict(raw)
    check_keys(raw, (*_TOP_LEVEL, *SECTIONS), "")
    # The sections first: a top-level key written after a [section] header belongs to that
    # section in TOML, and its error there (model under [sampler]) says what went wrong,
    # where the default model's needs would speak of something else.
    sections = {name: _parse_section_here(raw[name], name)
                for name in SECTIONS if name in raw and name in _SECTION_PARSERS}
    model = model_name(raw.get("model", "pendulum"), "model")
    compare = _parse_compare(raw.get("compare", []), model)
    gravity = float(number(raw.get("gravity_m_s2", STANDARD_GRAVITY), "gravity_m_s2",
                           positive=True))
    models = (model, *compare)
    geometric = [m for m in models if MODELS[m].needs_stick]
    stick = _parse_stick(table(raw["stick"], "stick")) if "stick" in raw else None
    if geometric and stick is None:
        raise ConfigError(f"stick: missing section (the {geometric[0]} model needs the "
                          "stick's shape and size)")
    priors = _parse_priors(table(raw.get("priors", {}), "priors"), models,
                           has_stick=stick is not None)
    if stick is not None and all(k in priors for k in ("pivot", "height")):
        _check_geometry(stick, priors)
    return Config(model=model, compare=compare, priors=priors, stick=stick, gravity=gravity,
                  sections=sections, raw=raw, path=path)


def _parse_section_here(value: Any, name: str) -> Any:
    """:func:`_parse_section`, saying where a top-level key it does not take belongs."""
    try:
        return _parse_section(value, name)
    except UnknownKey as exc:
        if exc.where != name or exc.key not in ("model", "compare", "gravity_m_s2"):
            raise
        raise ConfigError(f"{name}.{exc.key}: unknown key; {exc.key} belongs at the top of "
                          f"the file, before the first [section] (in TOML a key after "
                          f"[{name}] belongs to [{name}])") from None


def model_name(value: Any, where: str) -> str:
    """A model's name, ``MOTION`` or ``MOTION/LAW`` (``MOTION/constant`` is ``MOTION``)."""
    if isinstance(value, str):
        value = canonical_name(value)
    return string(value, where, MODELS)


def _parse_compare(value: Any, model: str) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list):
        raise ConfigError(f"compare: expected a list of model names, got {value!r}")
    names = [model_name(v, f"compare[{i}]") for i, v in enumerate(value)]
    return tuple(dict.fromkeys(n for n in names if n != model))


def _parse_stick(section: dict[str, Any]) -> StickSpec:
    shape = string(section.get("shape", "cylinder-cone"), "stick.shape", STICK_SHAPES)
    allowed = ("shape", "length_mm") if shape == "thin-rod" else ("shape", *STICK_DIMENSIONS)
    for key in section:
        if key in STICK_DIMENSIONS and key not in allowed:
            raise ConfigError(f"stick.{key}: only for shape = \"cylinder-cone\" (this stick is "
                              f"a {shape})")
    check_keys(section, allowed, "stick")
    dims = {}
    for key in allowed[1:]:
        if key not in section:
            raise ConfigError(f"stick.{key}: missing (the {shape} shape needs the "
                              f"{STICK_DIMENSIONS[key].description})")
        dims[STICK_DIMENSIONS[key].field] = parse_prior(section[key], STICK_DIMENSIONS[key],
                                                       f"stick.{key}")
    return StickSpec(shape=shape, **dims)


def _parse_priors(section: dict[str, Any], models: tuple[str, ...], has_stick: bool = False
                  ) -> dict[str, Distribution]:
    check_keys(section, PARAMETERS, "priors")
    priors = {PARAMETERS[key].name: parse_prior(value, PARAMETERS[key], f"priors.{key}")
              for key, value in section.items()}
    for model in models:
        for key in parameter_keys(model):
            spec = PARAMETERS[key]
            if spec.name in priors:
                continue
            if key == GEOMETRY_PREDICTS and has_stick:
                continue  # the geometry's prior predictive (inference.space.default_prior)
            if key in DEFAULT_PRIORS:
                priors[spec.name] = parse_prior(DEFAULT_PRIORS[key], spec, f"priors.{key}")
                continue
            if key not in DEFAULT_VALUES:
                predicted = (", or a [stick] section to predict it from"
                             if key == GEOMETRY_PREDICTS else "")
                raise ConfigError(f"priors.{key}: missing (the {model} model needs the "
                                  f"{spec.description}{predicted})")
            priors[spec.name] = Fixed(DEFAULT_VALUES[key] * spec.to_si)
    return priors


def _check_geometry(stick: StickSpec, priors: dict[str, Distribution]) -> None:
    """The nominal set-up must be able to drop and bounce (checked at the priors' medians)."""
    geometry = stick.nominal()
    pivot, height = priors["pivot"].median(), priors["height"].median()
    total, centre, _ = (float(v) for v in geometry.mass_properties(pivot))
    mm = 1e3
    if pivot >= centre:
        raise ConfigError(f"priors.pivot_mm: a pivot at {pivot * mm:g} mm is at or beyond the "
                          f"centre of mass (l_C = {centre * mm:.1f} mm), so the stick would not "
                          "fall; the pivot must lie between the butt and the centre of mass")
    reach = total - pivot
    if height >= reach:
        raise ConfigError(f"priors.height_mm: the tip cannot reach the drumhead from "
                          f"h = {height * mm:g} mm with the pivot at d = {pivot * mm:g} mm "
                          f"(needs h < L - d = {reach * mm:.1f} mm)")
    if stick.shape != "thin-rod" and not tip_strikes_first(
            stick.shape, geometry.tip, geometry.radius, height, reach):
        rim = math.degrees(math.atan2(geometry.radius, geometry.tip))
        raise ConfigError(
            f"priors.height_mm: at h = {height * mm:g} mm and d = {pivot * mm:g} mm the stick "
            f"meets the drumhead at {math.degrees(math.asin(height / reach)):.1f}°, below its "
            f"cone's half-angle atan(R / l2) = {rim:.1f}°, so the rim of the cone strikes before "
            f"the tip, which no model here describes (raise h above "
            f"{reach * math.sin(math.radians(rim)) * mm:.1f} mm)")
    angle = priors.get("release_angle", Fixed(0.0)).median()
    contact = math.asin(height / reach)
    if angle >= contact:
        raise ConfigError(f"priors.release_angle_deg: a release at {math.degrees(angle):g}° is "
                          f"at or below the contact angle ({math.degrees(contact):.1f}°), so "
                          "the stick would start on the drumhead")


def _parse_section(value: Any, name: str) -> Any:
    if name not in _SECTION_PARSERS:
        raise LookupError(f"no parser registered for the config section [{name}]: import the "
                          "stage that reads it first")
    return _SECTION_PARSERS[name](table(value, name), name)


