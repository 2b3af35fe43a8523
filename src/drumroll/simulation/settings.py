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
    jitter_ms = 0.0               # Gaussian scatter of the impact times about the model
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

Every impact holds the stick on the head for the contact time of ``[simulate.drum]``
(``contact_time_s`` at ``reference_speed_m_s``, scaled as speed^``contact_exponent``, Hertz's
−1/5): the synthetic drum's contact pulse lasts that long, and the next flight starts when it
ends, so impact k comes Σ_{j<k} τ_j later than the flights alone put it (the truth's
``physics.contact_ms`` is the first impact's τ). Recorded hits instead of the synthetic drum
(then ``[simulate.drum]`` does not apply but for that contact law, nor the synthetic
``spurious`` events: use ``extra_hits``), and a measured room instead of the
synthetic one (a string instead of the ``[simulate.room]`` table)::

    [simulate]
    hits = ["samples/snare-1.flac", "samples/snare-2.flac"]   # velocity layers, softest first
    layer_db = 6                  # one layer softer per 6 dB of level drop
    level_exponent = 1.2          # level = 20 * 1.2 * log10(v / v_max) dB ...
    level_spread_db = 1.5         # ... plus a Gaussian spread
    room = "samples/room-ir.flac" # a measured impulse response
    wet_db = -12                  # its reflections and reverberation re the dry sound
    clip_db = 6                   # drive 6 dB past peak_dbfs and clip there (any recording)
    extra_hits = [                # recorded sounds that are not impacts
      { file = "samples/side-stick.flac", time_s = -0.35, level_db = -6 },
      { file = "samples/tom.flac", after_last_s = 0.45 },
    ]

File names are relative to the config file's folder (absolute ones are taken as they are);
:func:`load_recorded` reads them. See :mod:`drumroll.simulation.hits` and
:mod:`drumroll.simulation.measured_room` for what the settings mean.

The stick is the config's ``[stick]`` at its nominal (median) dimensions, and g is the
config's ``gravity_m_s2``.
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from drumroll.config.loader import register_section
from drumroll.config.validate import boolean, check_keys, join, number, string, table, type_name
from drumroll.errors import AudioError, ConfigError, DrumrollWarning
from drumroll.physics.models import GEOMETRIC_MODELS
from drumroll.quantities import BY_NAME, DERIVED, QUANTITIES
from drumroll.simulation.disturbances import Disturbances
from drumroll.simulation.room import Room
from drumroll.simulation.sounds import DrumSound

if TYPE_CHECKING:
    from drumroll.simulation.hits import HitBank
    from drumroll.simulation.measured_room import MeasuredRoom
    from drumroll.simulation.render_hits import ExtraHit

#: Forward models that can make a recording's truth (they give impact speeds).
#: The models a simulation can take its truth from (those with a stick and a fall).
TRUTH_MODELS = GEOMETRIC_MODELS
SUBTYPES = ("PCM_16", "PCM_24", "FLOAT")
#: Upper bound on the number of rebounds, whichever way the roll's end is chosen.
MAX_BOUNCES = 400

#: The true values a simulation takes, by quantity key (drumroll.quantities): required ones.
_TRUTH_REQUIRED = ("alpha", "pivot_mm", "height_mm")
#: Numbers of the section (key → factor to SI): the truth's quantities, then the recording's.
_SCALARS: dict[str, float] = {
    **{key: QUANTITIES[key].to_si for key in (*_TRUTH_REQUIRED, "release_speed_m_s",
                                              "release_angle_deg", "jitter_ms")},
    "min_tip_speed_m_s": 1.0,
    "peak_dbfs": 1.0,
}
_OTHER = ("model", "n_bounces", "sample_rate", "subtype", "channels", "seed", "drum", "room",
          "disturbances", "clip_db")
_SUBSECTIONS = {"drum": DrumSound, "room": Room, "disturbances": Disturbances}
# Recorded hits' level keys: key → (default, low, high, the range in words)
_RECORDED: dict[str, tuple[float, float, float, str]] = {
    "layer_db": (6.0, 0.0, 60.0, "in (0, 60] dB"),
    "level_exponent": (1.2, 0.0, 10.0, "in (0, 10]"),
    "level_spread_db": (1.5, 0.0, 20.0, "in [0, 20] dB"),
}
_HITS_KEYS = ("hits", *_RECORDED, "extra_hits")
_EXTRA_KEYS = ("file", "time_s", "after_last_s", "level_db", "kind")
#: Most velocity layers a bank may have (a sampled kit has a handful, rarely more than 32).
MAX_LAYERS = 64


@dataclass(frozen=True)
class ExtraHitSpec:
    """A recorded sound that is not an impact, as the config names it.

    ``time_s`` counts from the roll's first impact, or from its last with ``after_last``;
    ``level_db`` is relative to the roll's loudest impact; ``kind`` names it in the truth
    (empty: the file's name).
    """

    file: str
    time_s: float
    after_last: bool = False
    level_db: float = 0.0
    kind: str = ""


@dataclass(frozen=True)
class SimulateSettings:
    """A validated ``[simulate]`` section (SI units).

    ``n_bounces`` (rebounds after the first impact) or ``min_tip_speed`` ends the roll; the
    other is None. ``hits`` (velocity layers, softest first) selects recorded hits over the
    synthetic ``drum``, ``room_file`` a measured room over the synthetic ``room``; file names
    are as written (relative to the config's folder). ``clip_db`` is None for no clipping.
    ``raw`` is the section as written, for the truth file.
    """

    alpha: float
    pivot: float
    height: float
    model: str = "pendulum"
    release_speed: float = 0.0
    release_angle: float = 0.0
    jitter: float = 0.0
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
    hits: tuple[str, ...] = ()
    layer_db: float = 6.0
    level_exponent: float = 1.2
    level_spread_db: float = 1.5
    extra_hits: tuple[ExtraHitSpec, ...] = ()
    room_file: str | None = None
    wet_db: float = -12.0
    clip_db: float | None = None
    raw: dict[str, Any] = field(default_factory=dict, compare=False)

    def describe(self) -> dict[str, Any]:
        """Every setting, defaults included, in the config's units (JSON-ready)."""
        return {
            "model": self.model, "alpha": self.alpha, "pivot_mm": self.pivot * 1e3,
            "height_mm": self.height * 1e3, "release_speed_m_s": self.release_speed,
            "release_angle_deg": math.degrees(self.release_angle),
            "jitter_ms": self.jitter * 1e3, "n_bounces": self.n_bounces,
            "min_tip_speed_m_s": self.min_tip_speed, "sample_rate": self.sample_rate,
            "subtype": self.subtype, "channels": self.channels, "peak_dbfs": self.peak_dbfs,
            **({"hits": list(self.hits), "layer_db": self.layer_db,
                "level_exponent": self.level_exponent, "level_spread_db": self.level_spread_db,
                "extra_hits": [{"file": x.file,
                                ("after_last_s" if x.after_last else "time_s"): x.time_s,
                                "level_db": x.level_db, "kind": x.kind}
                               for x in self.extra_hits]}
               if self.hits else {"drum": _plain(self.drum)}),
            **({"room": self.room_file, "wet_db": self.wet_db} if self.room_file
               else {"room": _plain(self.room)}),
            "disturbances": _plain(self.disturbances),
            **({"clip_db": self.clip_db} if self.clip_db else {}),
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
    check_keys(section, (*_SCALARS, *_OTHER, *_HITS_KEYS, "wet_db"), where)
    values: dict[str, Any] = {}
    for key, to_si in _SCALARS.items():
        if key not in section:
            if key in _TRUTH_REQUIRED:
                raise ConfigError(f"{join(where, key)}: missing (the true "
                                  f"{QUANTITIES[key].description})")
            continue
        values[key] = number(section[key], join(where, key)) * to_si
    alpha = values["alpha"]
    if not 0 < alpha <= 1:
        raise ConfigError(f"{join(where, 'alpha')}: must lie in (0, 1], got {alpha!r}")
    for key in ("pivot_mm", "jitter_ms", "release_speed_m_s"):
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
    room_file = _room_file(section, where)
    recorded = _parse_recorded(section, where)
    parts = {name: _parse_dataclass(cls, table(section.get(name, {}), join(where, name)),
                                    join(where, name))
             for name, cls in _SUBSECTIONS.items() if not (name == "room" and room_file)}
    if recorded and parts["disturbances"].spurious:
        raise ConfigError(f"{join(where, 'disturbances.spurious')}: the synthetic tap and knock "
                          f"need the synthetic drum; with {join(where, 'hits')} give "
                          f"{join(where, 'extra_hits')} instead")
    clip_db = section.get("clip_db")
    if clip_db is not None:
        clip_db = float(number(clip_db, join(where, "clip_db")))
        if not 0 <= clip_db <= 60:
            raise ConfigError(f"{join(where, 'clip_db')}: must lie in [0, 60] dB (0: no "
                              f"clipping), got {section['clip_db']!r}")
    return SimulateSettings(
        alpha=alpha, pivot=values["pivot_mm"], height=values["height_mm"],
        model=string(section.get("model", "pendulum"), join(where, "model"), TRUTH_MODELS),
        release_speed=values.get("release_speed_m_s", 0.0),
        release_angle=values.get("release_angle_deg", 0.0),
        jitter=values.get("jitter_ms", 0.0), n_bounces=n_bounces,
        min_tip_speed=min_speed, sample_rate=sample_rate,
        subtype=string(section.get("subtype", "PCM_16"), join(where, "subtype"), SUBTYPES),
        channels=channels, peak_dbfs=values.get("peak_dbfs", -1.0), seed=seed,
        room_file=room_file, wet_db=_wet_db(section, room_file, where), clip_db=clip_db or None,
        raw=dict(section), **parts, **recorded,
    )


def _room_file(section: dict[str, Any], where: str) -> str | None:
    """A measured room's file (``room = "ir.flac"``), or None for the synthetic room."""
    room = section.get("room")
    key = join(where, "room")
    if isinstance(room, dict) and "file" in room:
        raise ConfigError(f"{key}.file: a measured room is given as {key} = \"file\" (a "
                          "string), not inside the synthetic room's table")
    if room is None or isinstance(room, dict):
        return None
    if not isinstance(room, str):
        raise ConfigError(f"{key}: expected a file name (a measured room) or a table (a "
                          f"synthetic room), got {type_name(room)} ({room!r})")
    if not room.strip():
        raise ConfigError(f"{key}: empty file name")
    return room


def _wet_db(section: dict[str, Any], room_file: str | None, where: str) -> float:
    if "wet_db" not in section:
        return -12.0
    key = join(where, "wet_db")
    if room_file is None:
        raise ConfigError(f"{key}: only for a measured room ({join(where, 'room')} = "
                          "\"file\"); the synthetic room's table has its own levels")
    wet = float(number(section["wet_db"], key))
    if not -120 <= wet <= 40:
        raise ConfigError(f"{key}: must lie in [-120, 40] dB, got {section['wet_db']!r}")
    return wet


def _parse_recorded(section: dict[str, Any], where: str) -> dict[str, Any]:
    """The recorded-hit keys as SimulateSettings fields ({} without ``hits``)."""
    if "hits" not in section:
        for key in _HITS_KEYS:
            if key in section:
                raise ConfigError(f"{join(where, key)}: only with recorded hits "
                                  f"({join(where, 'hits')} = [\"soft.flac\", ...])")
        return {}
    hits = section["hits"]
    key = join(where, "hits")
    if isinstance(hits, str):
        hits = [hits]
    if not isinstance(hits, list) or not hits:
        raise ConfigError(f"{key}: expected an array of file names (velocity layers, softest "
                          f"first), got {hits!r}")
    if len(hits) > MAX_LAYERS:
        raise ConfigError(f"{key}: at most {MAX_LAYERS} velocity layers, got {len(hits)}")
    for i, name in enumerate(hits):
        if not isinstance(name, str) or not name.strip():
            raise ConfigError(f"{key}[{i}]: expected a file name, got {name!r}")
    if "drum" in section:
        raise ConfigError(f"{join(where, 'drum')}: does not apply with {key} (the recorded "
                          "hits are the drum)")
    out: dict[str, Any] = {"hits": tuple(hits)}
    for name, (default, low, high, text) in _RECORDED.items():
        value = float(number(section.get(name, default), join(where, name)))
        if not (low < value <= high if name != "level_spread_db" else low <= value <= high):
            raise ConfigError(f"{join(where, name)}: must lie {text}, got {section[name]!r}")
        out[name] = value
    extras = section.get("extra_hits", [])
    if not isinstance(extras, list):
        raise ConfigError(f"{join(where, 'extra_hits')}: expected an array of tables such as "
                          f"{{ file = \"tap.flac\", time_s = -0.3 }}, got {type_name(extras)}")
    out["extra_hits"] = tuple(_parse_extra(x, f"{join(where, 'extra_hits')}[{i}]")
                              for i, x in enumerate(extras))
    return out


def _parse_extra(entry: Any, where: str) -> ExtraHitSpec:
    entry = table(entry, where)
    check_keys(entry, _EXTRA_KEYS, where)
    if "file" not in entry:
        raise ConfigError(f"{join(where, 'file')}: missing (the sound's file)")
    file = string(entry["file"], join(where, "file"))
    if not file.strip():
        raise ConfigError(f"{join(where, 'file')}: empty file name")
    if ("time_s" in entry) == ("after_last_s" in entry):
        raise ConfigError(f"{join(where, 'time_s')}: give time_s (from the first impact; "
                          "negative: before the roll) or after_last_s (after the last "
                          "impact), exactly one")
    after_last = "after_last_s" in entry
    name = "after_last_s" if after_last else "time_s"
    time = float(number(entry[name], join(where, name), nonnegative=after_last))
    level = float(number(entry.get("level_db", 0.0), join(where, "level_db")))
    if not -120 <= level <= 40:
        raise ConfigError(f"{join(where, 'level_db')}: must lie in [-120, 40] dB, "
                          f"got {entry['level_db']!r}")
    return ExtraHitSpec(file=file, time_s=time, after_last=after_last, level_db=level,
                        kind=string(entry.get("kind", ""), join(where, "kind")))


@dataclass(frozen=True, eq=False)
class RecordedSources:
    """The recorded sounds a ``[simulate]`` section names, read at its sample rate.

    ``bank`` is None without ``hits``, ``room`` None without a measured room.
    """

    bank: HitBank | None
    room: MeasuredRoom | None
    extra_hits: tuple[ExtraHit, ...]


def load_recorded(settings: SimulateSettings, base: str | Path,
                  where: str = "simulate") -> RecordedSources:
    """Read the hits, the measured room and the extra hits a ``[simulate]`` section names.

    Parameters
    ----------
    settings
        The section.
    base
        The folder relative file names are taken from (the config file's).
    where
        The section's name, for messages.

    Raises
    ------
    ConfigError
        One line naming the key: a missing, unreadable, damaged or silent file.
    """
    from drumroll.simulation.hits import HitBank
    from drumroll.simulation.measured_room import MeasuredRoom
    from drumroll.simulation.render_hits import ExtraHit

    base = Path(base)
    fs = settings.sample_rate
    bank = None
    if settings.hits:
        paths = [_resolve(base, name, f"{join(where, 'hits')}[{i}]")
                 for i, name in enumerate(settings.hits)]
        bank = _load(join(where, "hits"), HitBank.load, paths, fs, names=settings.hits,
                     layer_db=settings.layer_db, level_exponent=settings.level_exponent,
                     level_spread_db=settings.level_spread_db)
    room = None
    if settings.room_file:
        path = _resolve(base, settings.room_file, join(where, "room"))
        room = _load(join(where, "room"), MeasuredRoom.load, path, fs, wet_db=settings.wet_db,
                     name=settings.room_file)
    extras = []
    for i, spec in enumerate(settings.extra_hits):
        key = f"{join(where, 'extra_hits')}[{i}].file"
        sound = _load(key, HitBank.load, [_resolve(base, spec.file, key)], fs,
                      names=[spec.file])
        extras.append(ExtraHit(sound=sound, time_s=spec.time_s, after_last=spec.after_last,
                               level_db=spec.level_db, kind=spec.kind))
    return RecordedSources(bank=bank, room=room, extra_hits=tuple(extras))


def _resolve(base: Path, name: str, key: str) -> Path:
    """The file ``name`` names, checked to be a readable recording (errors name ``key``)."""
    from drumroll.audio.io import probe

    path = Path(name).expanduser()
    path = path if path.is_absolute() else base / path
    if not path.exists():
        raise ConfigError(f"{key}: no such file {name!r} (looked for {path}; file names are "
                          "relative to the config file's folder)")
    _load(key, probe, path)
    return path


def _load(key: str, loader: Any, *args: Any, **kwargs: Any) -> Any:
    """Call a loader, turning its one-line errors into ConfigErrors naming ``key``."""
    try:
        return loader(*args, **kwargs)
    except (AudioError, ValueError) as exc:
        raise ConfigError(f"{key}: {exc}") from None


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
        ``model_times_s`` (from the first impact, exact physics, each impact's contact
        time, :meth:`~drumroll.simulation.sounds.DrumSound.contact_times`, delaying the
        flights after it), ``times_s`` (with the jitter, re-sorted), ``speeds_m_s`` and the
        physics summary ``physics`` (t_c, t_b, θ_C, ω_C, contact tip speed, the first
        impact's contact time ``contact_ms``).

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
    # The onset is the start of contact and the next flight starts at its end (physics.md):
    # each impact comes the contacts before it later than the flights alone put it.
    contact = settings.drum.contact_times(speeds)
    times = times + np.concatenate(([0.0], np.cumsum(contact[:-1])))
    jittered = np.sort(times + settings.jitter * rng.standard_normal(len(times)))
    physics = {key: q.to_user(float(np.ravel(getattr(bounces, q.bounces))[0]))
               for key, q in DERIVED.items()}
    physics[BY_NAME["contact"].key] = BY_NAME["contact"].to_user(float(contact[0]))
    return {"model_times_s": times, "times_s": jittered, "speeds_m_s": speeds,
            "physics": physics}


register_section("simulate", parse_simulate)
