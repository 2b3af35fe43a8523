"""Realistic drumroll recordings with known truth, for tests and benchmarks.

:func:`render` mixes impacts of a :class:`DrumSound` in a :class:`Room` with
:class:`Disturbances` (noise, hum, stray sounds) and returns a :class:`Rendering`: the samples
and the truth (impact times, speeds, per-impact local SNR, spurious events). See
:mod:`drumroll.simulation.render` for the truth conventions.
"""

from __future__ import annotations

from drumroll.simulation.disturbances import Disturbances
from drumroll.simulation.render import Rendering, render
from drumroll.simulation.room import Room
from drumroll.simulation.sounds import DrumSound

__all__ = ["Disturbances", "DrumSound", "Rendering", "Room", "render"]
