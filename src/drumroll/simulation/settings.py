"""The config's ``[simulate]`` section: the true set-up and the recording to make of it.

Units are the config's (mm, degrees, ms, m/s); :class:`SimulateSettings` holds SI values.
Example::

    [simulate]
    model = "pendulum"            # physics of the truth: "pendulum" (exact) or "small-angle"
    alpha = 0.88                  # true coefficient of restitution
    pivot_mm = 131
    height_mm = 80
    release_speed_m_s = 0.0
    release_angle_deg = 0.0
    timing_jitter_ms = 0.0        # Gaussian scatter of the impact times about the model
    min_tip_speed_m_s = 0.03      # stop once the tip hits slower than this ...
    # n_bounces = 30              # ... or after exactly this many rebounds (not both)
    sample_rate = 44100
    subtype = "PCM_16"            # "PCM_16" | "PCM_24" | "FLOAT"
    channels = 1
    peak_dbfs = -1.0
    seed = 1                      # default seed; --seed overrides

    [simulate.drum]               # any field of drumroll.simulation.DrumSound
    fundamental_hz = 200
    [simulate.room]               # any field of drumroll.simulation.Room
    echo = true
    reverb_time_s = 0.4
    [simulate.disturbances]       # any field of drumroll.simulation.Disturbances
    snr_db = 30                   # false: no background noise
    hum_hz = 50                   # false (the default): no hum

The stick is the config's ``[stick]`` at its nominal (median) dimensions, and g is the
config's ``gravity_m_s2``.
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drumroll.config.validate import boolean, check_keys, join, number, string, table, type_name
from drumroll.errors import ConfigError, DrumrollWarning
from drumroll.simulation.disturbances import Disturbances
from drumroll.simulation.room import Room
from drumroll.simulation.sounds import DrumSound

#: Forward models that can make a recording's truth (they give impact speeds).
TRUTH_MODELS = ("pendulum", "small-angle")
SUBTYPES = ("PCM_16", "PCM_24", "FLOAT")
#: Upper bound on the number of rebounds, whichever way the roll's end is chosen.
MAX_BOUNCES = 400

# key: (description for "missing" messages, factor to SI, required)
_SCALARS: dict[str, tuple[str, float, bool]] = {
    "alpha": ("true coefficient of restitution", 1.0, True),
    "pivot_mm": ("true pivot distance from the butt", 1e-3, True),
    "height_mm": ("true pivot height above the drumhead", 1e-3, True),
    "release_speed_m_s": ("", 1.0, False),
    "release_angle_deg": ("", math.pi / 180, False),
    "timing_jitter_ms": ("", 1e-3, False),
    "min_tip_speed_m_s": ("", 1.0, False),
    "peak_dbfs": ("", 1.0, False),
}
_OTHER = ("model", "n_bounces", "sample_rate", "subtype", "channels", "seed", "drum", "room",
          "disturbances")
_SUBSECTIONS = {"drum": DrumSound, "room": Room, "disturbances": Disturbances}


@dataclass(frozen=True)
class SimulateSettings:
    """A validated ``[simulate]`` section (SI units).

    ``n_bounces`` (rebounds after the first impact) or ``min_tip_speed`` ends the roll; the
    other is None. ``raw`` is the section as written, for the truth file.
    """

    alpha: float
    pivot: float
    height: float
    model: str = "pendulum"
    release_speed: float = 0.0
    release_angle: float = 0.0
    timing_jitter: float = 0.0
    n_bounces: int | None = None
    min_tip_speed: float | None = 0.03
    sample_rate: int = 44100
    subtype: str = "PCM_16"
    channels: int = 1
    peak_dbfs: float = -1.0
    seed: int | None = None
    drum: DrumSound = field(default_factory=DrumSound)
    room: Room = field(default_factory=Room)
    disturbances: Disturbances = field(default_factory=Disturbances)
    raw: dict[str, Any] = field(default_factory=dict, compare=False)

    def describe(self) -> dict[str, Any]:
        """Every setting, defaults included, in the config's units (JSON-ready)."""
        return {
            "model": self.model, "alpha": self.alpha, "pivot_mm": self.pivot * 1e3,
            "height_mm": self.height * 1e3, "release_speed_m_s": self.release_speed,
            "release_angle_deg": math.degrees(self.release_angle),
            "timing_jitter_ms": self.timing_jitter * 1e3, "n_bounces": self.n_bounces,
            "min_tip_speed_m_s": self.min_tip_speed, "sample_rate": self.sample_rate,
            "subtype": self.subtype, "channels": self.channels, "peak_dbfs": self.peak_dbfs,
            "drum": _plain(self.drum), "room": _plain(self.room),
            "disturbances": _plain(self.disturbances),
        }


def _plain(obj: Any) -> dict[str, Any]:
    return {k: list(v) if isinstance(v, tuple) else v
            for k, v in dataclasses.asdict(obj).items()}


def parse_simulate(section: dict[str, Any], where: str = "simulate") -> SimulateSettings:
    """Validate a ``[simulate]`` table (see the module docstring).

    Raises
    ------
    ConfigError
        One line naming the key: unknown keys (with a suggestion), missing truth values,
        wrong types, values out of range.
    """
    check_keys(section, (*_SCALARS, *_OTHER), where)
    values: dict[str, Any] = {}
    for key, (description, to_si, required) in _SCALARS.items():
        if key not in section:
            if required:
                raise ConfigError(f"{join(where, key)}: missing (the {description})")
            continue
        values[key] = number(section[key], join(where, key)) * to_si
    alpha = values["alpha"]
    if not 0 < alpha <= 1:
        raise ConfigError(f"{join(where, 'alpha')}: must lie in (0, 1], got {alpha!r}")
    for key in ("pivot_mm", "timing_jitter_ms", "release_speed_m_s"):
        if key in values and values[key] < 0:
            raise ConfigError(f"{join(where, key)}: must not be negative, got {section[key]!r}")
    if values["height_mm"] <= 0:
        raise ConfigError(f"{join(where, 'height_mm')}: must be positive, "
                          f"got {section['height_mm']!r}")
    if not -90 < section.get("release_angle_deg", 0) < 90:
        raise ConfigError(f"{join(where, 'release_angle_deg')}: must lie in (-90, 90), "
                          f"got {section['release_angle_deg']!r}")
    if values.get("peak_dbfs", -1.0) > 0:
        raise ConfigError(f"{join(where, 'peak_dbfs')}: must be 0 or less (full scale), "
                          f"got {section['peak_dbfs']!r}")
    n_bounces, min_speed = _roll_end(section, values, where)
    sample_rate = int(number(section.get("sample_rate", 44100), join(where, "sample_rate"),
                             integer=True))
    if not 8000 <= sample_rate <= 384000:
        raise ConfigError(f"{join(where, 'sample_rate')}: must lie in [8000, 384000] Hz, "
                          f"got {sample_rate}")
    channels = int(number(section.get("channels", 1), join(where, "channels"), integer=True))
    if not 1 <= channels <= 8:
        raise ConfigError(f"{join(where, 'channels')}: must be 1 to 8, got {channels}")
    seed = section.get("seed")
    if seed is not None:
        seed = int(number(seed, join(where, "seed"), integer=True, nonnegative=True))
    parts = {name: _parse_dataclass(cls, table(section.get(name, {}), join(where, name)),
                                    join(where, name))
             for name, cls in _SUBSECTIONS.items()}
    return SimulateSettings(
        alpha=alpha, pivot=values["pivot_mm"], height=values["height_mm"],
        model=string(section.get("model", "pendulum"), join(where, "model"), TRUTH_MODELS),
        release_speed=values.get("release_speed_m_s", 0.0),
        release_angle=values.get("release_angle_deg", 0.0),
        timing_jitter=values.get("timing_jitter_ms", 0.0), n_bounces=n_bounces,
        min_tip_speed=min_speed, sample_rate=sample_rate,
        subtype=string(section.get("subtype", "PCM_16"), join(where, "subtype"), SUBTYPES),
        channels=channels, peak_dbfs=values.get("peak_dbfs", -1.0), seed=seed,
        raw=dict(section), **parts,
    )


def _roll_end(section: dict[str, Any], values: dict[str, Any], where: str
              ) -> tuple[int | None, float | None]:
    if "n_bounces" in section and "min_tip_speed_m_s" in section:
        raise ConfigError(f"{join(where, 'n_bounces')}: give n_bounces or min_tip_speed_m_s, "
                          "not both")
    if "n_bounces" in section:
        n = int(number(section["n_bounces"], join(where, "n_bounces"), integer=True))
        if not 0 <= n <= MAX_BOUNCES:
            raise ConfigError(f"{join(where, 'n_bounces')}: must be 0 to {MAX_BOUNCES}, got {n}")
        return n, None
    speed = values.get("min_tip_speed_m_s", 0.03)
    if not speed > 0:
        raise ConfigError(f"{join(where, 'min_tip_speed_m_s')}: must be positive, "
                          f"got {section['min_tip_speed_m_s']!r}")
    return None, speed


def _parse_dataclass(cls: type, section: dict[str, Any], where: str) -> Any:
    """Build ``cls`` from a TOML table, checking each value against the field's type.

    ``false`` switches off an optional (``... | None``) field; arrays fill tuple fields.
    The dataclass's own range checks become one-line errors naming the key.
    """
    fields = {f.name: f for f in dataclasses.fields(cls)}
    check_keys(section, fields, where)
    kwargs = {name: _field_value(str(fields[name].type), value, join(where, name))
              for name, value in section.items()}
    try:
        return cls(**kwargs)
    except ValueError as exc:
        match = re.match(r"^\w+\.(\w+) (.*)$", str(exc))
        key, text = (match.group(1), match.group(2)) if match else ("", str(exc))
        raise ConfigError(f"{join(where, key) if key else where}: {text}") from None


def _field_value(kind: str, value: Any, key: str) -> Any:
    optional = "None" in kind
    kind = kind.replace("| None", "").strip()
    if optional and value is False:
        return None
    if kind == "bool":
        return boolean(value, key)
    if kind == "int":
        return int(number(value, key, integer=True))
    if kind == "float":
        return float(number(value, key))
    if kind.startswith("tuple"):
        if not isinstance(value, list):
            raise ConfigError(f"{key}: expected an array of numbers, got {type_name(value)} "
                              f"({value!r})")
        items = tuple(float(number(v, f"{key}[{i}]")) for i, v in enumerate(value))
        if "..." not in kind and len(items) != kind.count("float"):
            raise ConfigError(f"{key}: expected {kind.count('float')} numbers, "
                              f"got {len(items)}")
        return items
    raise ConfigError(f"{key}: cannot be set from a config")  # pragma: no cover


def true_impacts(settings: SimulateSettings, stick: Any, gravity: float,
                 rng: np.random.Generator) -> dict[str, Any]:
    """The true roll: impact times (jittered and not) and tip speeds at impact.

    Parameters
    ----------
    settings
        The ``[simulate]`` section.
    stick
        :class:`~drumroll.physics.StickGeometry` of the true stick.
    gravity
        g (m/s²).
    rng
        Source of the timing jitter.

    Returns
    -------
    dict
        ``model_times_s`` (from the first impact, exact physics), ``times_s`` (with the
        jitter, re-sorted), ``speeds_m_s`` and the physics summary ``physics`` (t_c, t_b,
        θ_C, ω_C, contact tip speed).

    Raises
    ------
    ConfigError
        When the true set-up cannot make a drumroll (the reason names the key to change).
    """
    from drumroll.physics import bounce_sequence

    bounces = bounce_sequence(
        settings.model, alpha=settings.alpha, n_flights=settings.n_bounces or MAX_BOUNCES,
        pivot=settings.pivot, height=settings.height, release_speed=settings.release_speed,
        release_angle=settings.release_angle, stick=stick, g=gravity)
    if not bool(np.all(bounces.valid)):
        raise ConfigError(f"simulate: this set-up cannot make a drumroll: "
                          f"{bounces.reasons()[0]}")
    times = np.ravel(bounces.impacts)
    speeds = np.ravel(bounces.impact_tip_speeds)
    if settings.n_bounces is None:
        if speeds[0] < settings.min_tip_speed:
            raise ConfigError(f"simulate.min_tip_speed_m_s: the first impact is already slower "
                              f"({speeds[0]:.3g} m/s)")
        keep = int(np.sum(speeds >= settings.min_tip_speed))
        if keep == len(speeds):
            warnings.warn(f"simulate: the roll was cut at {MAX_BOUNCES} rebounds, before the "
                          f"tip speed fell below min_tip_speed_m_s = {settings.min_tip_speed:g}",
                          DrumrollWarning, stacklevel=2)
        times, speeds = times[:keep], speeds[:keep]
    jittered = np.sort(times + settings.timing_jitter * rng.standard_normal(len(times)))
    return {
        "model_times_s": times, "times_s": jittered, "speeds_m_s": speeds,
        "physics": {"t_c_s": float(np.ravel(bounces.t_c)[0]),
                    "t_b_s": float(np.ravel(bounces.t_b)[0]),
                    "theta_c_deg": math.degrees(float(np.ravel(bounces.theta_c)[0])),
                    "omega_c_rad_s": float(np.ravel(bounces.omega_c)[0]),
                    "contact_tip_speed_m_s": float(np.ravel(bounces.tip_speed_c)[0])},
    }
