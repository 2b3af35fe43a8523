"""``drumroll simulate`` as a function: a config's ``[simulate]`` section made into a
recording with its truth (:func:`simulate`); the command writes them to files."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drumroll._version import __version__
from drumroll.config import Config, load_config
from drumroll.errors import ConfigError
from drumroll.simulation.render import Rendering, render
from drumroll.simulation.render_hits import render_hits
from drumroll.simulation.settings import (
    RecordedSources,
    SimulateSettings,
    load_recorded,
    true_impacts,
)


@dataclass(frozen=True)
class Simulated:
    """A simulated recording.

    Attributes
    ----------
    rendering
        The audio (:attr:`samples`) and the rendering's own truth.
    sample_rate
        Samples per second.
    truth
        What was simulated, as the truth file holds it: the rendering's truth (impact times
        and speeds, local SNRs, stray sounds), the noise-free model impact times, the
        ``[simulate]`` settings, the stick, gravity and the physics of the roll, under the
        quantity registry's keys.
    settings
        The parsed ``[simulate]`` section.
    """

    rendering: Rendering
    sample_rate: int
    truth: dict[str, Any]
    settings: SimulateSettings

    @property
    def samples(self) -> NDArray[np.float64]:
        """The audio, (frames,) or (frames, channels), full scale ±1."""
        return self.rendering.samples


def render_roll(settings: SimulateSettings, sources: RecordedSources, times_s: NDArray,
                speeds_m_s: NDArray, rng: np.random.Generator) -> Rendering:
    """The recording of a roll's impacts (times from any origin, tip speeds) as a
    ``[simulate]`` section's sound makes it: its recorded hits or synthetic drum, its room,
    its disturbances and level (``sources``: what :func:`load_recorded` read for it). The one
    renderer of ``drumroll simulate`` and of ``drumroll calibrate --audio``."""
    room = settings.room if sources.room is None else sources.room
    if sources.bank is not None:
        return render_hits(times_s, speeds_m_s, bank=sources.bank, room=room,
                           disturbances=settings.disturbances, channels=settings.channels,
                           extra_hits=sources.extra_hits, rng=rng,
                           peak_dbfs=settings.peak_dbfs, clip_db=settings.clip_db)
    return render(times_s, speeds_m_s, sample_rate=settings.sample_rate, drum=settings.drum,
                  room=room, disturbances=settings.disturbances, channels=settings.channels,
                  rng=rng, peak_dbfs=settings.peak_dbfs, clip_db=settings.clip_db)


def simulate(config: Config | str | os.PathLike[str], seed: int | None = None) -> Simulated:
    """Make the recording a config's ``[simulate]`` section describes.

    Parameters
    ----------
    config
        A config (with ``[stick]`` and ``[simulate]``), or the path of its file; recorded
        hits and rooms it names are found relative to the file.
    seed
        Seed of the roll's scatter and the sound (None: the section's ``seed``, else 0).

    Raises
    ------
    ConfigError
        A missing section or a set-up that makes no roll; one line.
    """
    if not isinstance(config, Config):
        config = load_config(config)
    lead = f"{config.path}: " if config.path else ""
    settings: SimulateSettings | None = config.section("simulate")
    if settings is None:
        raise ConfigError(f"{lead}simulate: missing section (the true set-up and the "
                          "recording to make)")
    if config.stick is None:
        raise ConfigError(f"{lead}stick: missing section (the simulation needs the stick's "
                          "shape and size)")
    if seed is not None and seed < 0:
        raise ConfigError(f"seed: must not be negative, got {seed}")
    base = Path(config.path).parent if config.path else Path.cwd()
    try:
        sources = load_recorded(settings, base)
    except ConfigError as exc:
        raise ConfigError(f"{lead}{exc}") from None
    seed = seed if seed is not None else (settings.seed or 0)
    rng_roll, rng_sound = np.random.default_rng(seed).spawn(2)
    stick = config.stick.nominal()
    try:
        roll = true_impacts(settings, stick, config.gravity, rng_roll)
    except ConfigError as exc:
        raise ConfigError(f"{lead}{exc}") from None
    rendering = render_roll(settings, sources, roll["times_s"], roll["speeds_m_s"], rng_sound)
    truth = {
        "drumroll_version": __version__,
        "seed": seed,
        **rendering.truth(),
        "model_impact_times_s": [float(t) for t in roll["model_times_s"]
                                 + rendering.lead_in_s],
        "simulate": settings.describe(),
        "stick": {"shape": stick.shape, "length_mm": float(stick.length) * 1e3,
                  "tip_mm": float(stick.tip) * 1e3, "radius_mm": float(stick.radius) * 1e3},
        "gravity_m_s2": config.gravity,
        "physics": roll["physics"],
    }
    return Simulated(rendering=rendering, sample_rate=settings.sample_rate, truth=truth,
                     settings=settings)
