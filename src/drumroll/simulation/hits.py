"""A bank of recorded drum hits in velocity layers, and how loud each impact of a roll is.

Sample start (this defines the truth)
-------------------------------------
An impact's time is where its sample's own first sound begins. For a sample ``x`` (mono, at
the rendering's rate) with peak ``P = max |x|``:

1. ``i10`` is the first sample with ``|x| >= 0.1 P`` (-20 dB re peak): by then the hit is
   certainly under way.
2. The leading noise floor ``N`` is measured on ``x`` up to 1 ms before ``i10`` (a hit's
   faint precursors, such as a snare's low-frequency pressure swing, last up to 0.7 ms in
   the bundled samples, so they stay out of it): the RMS estimated from the median of
   ``x**2`` (divided by 0.455, the median of a unit Gaussian's square), robust to a stray
   click. If that stretch is shorter than 0.5 ms, no floor can be measured (the file starts
   with the sound) and ``N = 0``.
3. The start is the first sample with ``|x| >= max(10 N, 0.01 P)``: 20 dB above the floor,
   so that noise cannot cross it (Gaussian noise exceeds 10 times its RMS once in 10**23
   samples), and at least 1 % of the peak (-40 dB), so that the dither of a clean file
   cannot either.

In a lossy-coded file (OGG Vorbis, Opus, MP3) the start is instead the first sample with
``|x| >= 0.1 P``, where the hit is under way: a transform codec spreads its quantisation
noise up to about one short block (a few ms) ahead of a transient (*pre-echo*), and in the
bundled claves that noise rises from -40 to -22 dB re peak over the
2 ms before the strike, where the 1 % rule would put the start. Below -20 dB, nothing before
a lossy file's transient can be told from that noise.

1 % of the peak is low enough to keep the faint precursors that belong to a hit (the snare
swing above, at about -30 dB, precedes the stick's main attack by 0.7 ms in some of the AVL
layers) and lies 20 dB or more above the bundled samples' floors (-60 to -85 dB re peak).
Everything before the start is cut off, so nothing of an impact's sound precedes its time
(the faint rise below the threshold, a few samples, is lost). The start is found after
resampling: the resampler's pre-ringing is cut off with the rest, and the truth is exact at
every rate.

Levels and layers
-----------------
Each layer is normalised to unit RMS over the 10 ms after its start (the reference window
of :mod:`drumroll.simulation.disturbances`), so the bank's own recording levels do not
matter. Impact ``k`` of a roll whose fastest impact has tip speed ``v_max`` then has

* the nominal level ``L_k = 20 * level_exponent * log10(v_k / v_max)`` dB (0 dB for the
  fastest impact): the peak contact force of an elastic (Hertzian) impact grows as
  ``v**1.2``, and the radiated pressure with the force, hence the default exponent 1.2;
* the level ``L_k + level_spread_db * z_k`` with ``z_k`` standard Gaussian: hit-to-hit
  variation at the same speed (where on the head the tip lands, the stick's angle);
* the layer (the timbre) chosen by the nominal level: the loudest layer for the fastest
  impact and one layer softer per ``layer_db`` of level drop, down to the softest. A drum
  sounds duller the softer it is hit; a sampled kit captures this in layers recorded at
  about 6 dB steps of hit strength.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from drumroll.simulation.disturbances import REFERENCE_WINDOW_S
from drumroll.simulation.sample_files import is_lossy, read_mono

#: Sample start: the lowest level a start may have, relative to the sample's peak (1 %).
START_PEAK_FRACTION = 0.01
#: Sample start: a level the hit has certainly reached once it is under way (-20 dB).
START_UNDER_WAY_FRACTION = 0.1
#: Sample start: how long before the hit is under way its faint precursors may begin.
START_PRECURSOR_S = 1.0e-3
#: Sample start: how far above the leading noise floor the start must be (20 dB).
START_FLOOR_MARGIN_DB = 20.0
#: Sample start: the shortest leading stretch a noise floor is measured on.
START_FLOOR_MIN_S = 0.5e-3
#: Median of the square of a standard Gaussian: turns a median of x**2 into a variance.
_MEDIAN_CHI2_1 = 0.4549364231195724


def sound_start(x: np.ndarray, sample_rate: int, *, lossy: bool = False) -> int:
    """Index of the first sample of a recorded hit's own sound (see the module docstring).

    Parameters
    ----------
    x
        The recording, mono.
    sample_rate
        Its samples per second (sets the 0.5 ms needed to measure a floor).
    lossy
        The recording was lossy-coded: start where the hit is under way (10 % of the peak),
        not in the codec's pre-echo.

    Returns
    -------
    int
        The first sample with ``|x| >= max(10 * floor, 0.01 * peak)`` (lossless) or
        ``|x| >= 0.1 * peak`` (lossy).

    Raises
    ------
    ValueError
        For a silent recording.
    """
    a = np.abs(np.asarray(x, dtype=float))
    peak = float(a.max()) if a.size else 0.0
    if not peak > 0:
        raise ValueError("the sample is silent")
    under_way = int(np.argmax(a >= START_UNDER_WAY_FRACTION * peak))
    if lossy:
        return under_way
    lead = under_way - round(START_PRECURSOR_S * sample_rate)
    floor = 0.0
    if lead >= START_FLOOR_MIN_S * sample_rate:
        floor = float(np.sqrt(np.median(a[:lead] ** 2) / _MEDIAN_CHI2_1))
    threshold = max(10 ** (START_FLOOR_MARGIN_DB / 20) * floor, START_PEAK_FRACTION * peak)
    return int(np.argmax(a >= threshold))


@dataclass(frozen=True, eq=False)
class HitBank:
    """Recorded hits of one instrument in velocity layers, trimmed and level-normalised.

    Build it with :meth:`load`. ``layers[0]`` is the softest.

    Attributes
    ----------
    layers
        Each layer's samples from its start (see the module docstring), scaled to unit RMS
        over the 10 ms after the start.
    sample_rate
        Samples per second of ``layers``.
    names
        Each layer's file as the user named it (for the truth).
    starts_s
        Where each layer's start lies in its file (seconds, at ``sample_rate``).
    layer_db
        Level drop (dB) from one layer to the next softer one.
    level_exponent
        Sound pressure grows as the impact speed to this power.
    level_spread_db
        Standard deviation (dB) of the hit-to-hit level variation at the same speed.
    """

    layers: tuple[np.ndarray, ...] = field(repr=False)
    sample_rate: int
    names: tuple[str, ...]
    starts_s: tuple[float, ...]
    layer_db: float = 6.0
    level_exponent: float = 1.2
    level_spread_db: float = 1.5

    def __post_init__(self) -> None:
        if not self.layers or len(self.layers) != len(self.names):
            raise ValueError("HitBank.layers must be non-empty, one per name")
        if not self.layer_db > 0:
            raise ValueError(f"HitBank.layer_db must be > 0, got {self.layer_db!r}")
        if not 0 < self.level_exponent <= 10:
            raise ValueError(f"HitBank.level_exponent must be in (0, 10], "
                             f"got {self.level_exponent!r}")
        if not 0 <= self.level_spread_db <= 20:
            raise ValueError(f"HitBank.level_spread_db must be in [0, 20], "
                             f"got {self.level_spread_db!r}")

    @classmethod
    def load(cls, paths: Sequence[str | os.PathLike[str]], sample_rate: int, *,
             names: Sequence[str] | None = None, layer_db: float = 6.0,
             level_exponent: float = 1.2, level_spread_db: float = 1.5) -> HitBank:
        """Read velocity layers from files ordered softest to loudest.

        Parameters
        ----------
        paths
            One file per layer, softest first; a single file is a single layer.
        sample_rate
            Rate to resample to (the rendering's).
        names
            How to name the files in the truth (default: the paths as given).
        layer_db, level_exponent, level_spread_db
            See the class attributes.

        Raises
        ------
        drumroll.errors.AudioError
            A file that is missing, not audio or damaged (one line naming it).
        ValueError
            A silent file, or settings out of range.
        """
        layers, starts = [], []
        n_ref = max(1, round(REFERENCE_WINDOW_S * sample_rate))
        for path in paths:
            x = read_mono(path, sample_rate)
            try:
                i0 = sound_start(x, sample_rate, lossy=is_lossy(path))
            except ValueError:
                raise ValueError(f"{path}: the sample is silent") from None
            hit = x[i0:]
            rms = float(np.sqrt(np.mean(hit[:n_ref] ** 2)))
            layers.append(hit / rms)
            starts.append(i0 / sample_rate)
        return cls(layers=tuple(layers), sample_rate=int(sample_rate),
                   names=tuple(names) if names is not None else tuple(str(p) for p in paths),
                   starts_s=tuple(starts), layer_db=float(layer_db),
                   level_exponent=float(level_exponent),
                   level_spread_db=float(level_spread_db))

    def nominal_levels_db(self, speeds_m_s: np.ndarray) -> np.ndarray:
        """``20 * level_exponent * log10(v / max v)``: 0 dB for the fastest impact."""
        v = np.asarray(speeds_m_s, dtype=float)
        return 20 * self.level_exponent * np.log10(v / np.max(v))

    def layer_indices(self, nominal_db: np.ndarray) -> np.ndarray:
        """The layer of each impact: the loudest at 0 dB, one softer per ``layer_db``."""
        drop = np.floor(np.maximum(-np.asarray(nominal_db, dtype=float), 0.0) / self.layer_db)
        return np.clip(len(self.layers) - 1 - drop, 0, len(self.layers) - 1).astype(int)

    def plan(self, speeds_m_s: np.ndarray, rng: np.random.Generator
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each impact's layer, nominal level and drawn level (dB re the fastest impact).

        Parameters
        ----------
        speeds_m_s
            Impact tip speeds (positive).
        rng
            Source of the level spread (one standard normal per impact, always drawn).

        Returns
        -------
        layers, nominal_db, level_db
        """
        nominal = self.nominal_levels_db(speeds_m_s)
        level = nominal + self.level_spread_db * rng.standard_normal(nominal.size)
        return self.layer_indices(nominal), nominal, level
