"""Realistic drumroll recordings with known truth, for tests and benchmarks.

:func:`render` mixes impacts of a :class:`DrumSound` in a :class:`Room` with
:class:`Disturbances` (noise, hum, stray sounds) and returns a :class:`Rendering`: the samples
and the truth (impact times, speeds, per-impact local SNR, spurious events). See
:mod:`drumroll.simulation.render` for the truth conventions.

:func:`render_hits` makes the same kind of recording from real recorded hits (a
:class:`HitBank` of velocity layers, :class:`ExtraHit` sounds that are not impacts) in a
synthetic or :class:`MeasuredRoom`.
"""

from __future__ import annotations

from drumroll.simulation.disturbances import Disturbances
from drumroll.simulation.hits import HitBank
from drumroll.simulation.measured_room import MeasuredRoom
from drumroll.simulation.render import Rendering, render
from drumroll.simulation.render_hits import ExtraHit, render_hits
from drumroll.simulation.room import Room
from drumroll.simulation.sounds import DrumSound

__all__ = ["Disturbances", "DrumSound", "ExtraHit", "HitBank", "MeasuredRoom", "Rendering",
           "Room", "render", "render_hits"]
