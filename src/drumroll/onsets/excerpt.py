"""The audio around one roll, and the measurements every later stage makes on it.

The first pass streams the whole recording once and keeps only candidates. Everything after
it works on one roll at a time, on an :class:`Excerpt`: the raw samples from a little before
the roll's first impact to a little after its predicted end, with the first pass's band
energies on the same absolute frame grid (so detection functions with other windows can be
computed on demand), and the wide high-pass that onsets are refined on.
:meth:`Excerpt.refine` times one onset there, with or without a prior.
"""

from __future__ import annotations

import numpy as np

from drumroll.onsets.candidates import (
    FLOOR_PER_SAMPLE,
    combined_z,
    refine_window,
    settle_samples,
)
from drumroll.onsets.dsp import butter_sos
from drumroll.onsets.odf import FilterStream, OdfParams, band_filters, frame_energy, wide_filter
from drumroll.onsets.refine import Prior, Refined

#: Lower edge of the band whose power envelope shows an impact's attack (Hz): a stick's
#: click, snare wires, the contact's broadband burst are above it; a drum's and a table's
#: long-ringing low modes below it.
BAND_HZ = 1000.0

#: Width of one bin of the power envelope (seconds): half the detection function's finest
#: hop.
BIN_S = 0.25e-3


class Excerpt:
    """Raw samples around a roll, their band energies, and detection functions on demand.

    Parameters
    ----------
    x
        Mono samples.
    start
        Absolute sample index of ``x[0]``.
    sample_rate
        Samples per second.
    odf
        Detection-function settings (the bands and the hop of the first pass).
    codec_block
        For a lossy file, the stretch (samples) its codec may spread noise ahead of an
        impact by (:func:`~.refine.out_of_codec_noise`); 0 for lossless audio.
    floor_s
        For a lossy file, its codec's timing floor (sd, seconds;
        :func:`~drumroll.audio.timing.timing_floor`), allowed for wherever an onset is
        tested against the flight law (:func:`~.start.with_floor`); 0 for lossless audio.
    """

    def __init__(self, x: np.ndarray, start: int, sample_rate: int, odf: OdfParams,
                 codec_block: int = 0, floor_s: float = 0.0) -> None:
        self.x, self.start, self.sr, self.odf = x, start, sample_rate, odf
        self.codec_block = int(codec_block)
        self.floor_s = float(floor_s)
        self.hop = odf.hop(sample_rate)
        # Frames on the absolute grid of the first pass.
        self.skip = (-start) % self.hop
        self.f0 = (start + self.skip) // self.hop
        self.energy = []
        for filt in band_filters(odf, sample_rate):
            self.energy.append(frame_energy(filt(x)[self.skip:], self.hop))
        wide = wide_filter(odf, sample_rate)
        self.settle = settle_samples(wide.sos, sample_rate)
        self.wide = wide.filter
        self.segment = odf.frames(0.25, sample_rate)
        self._z: dict[tuple[int, int], np.ndarray] = {}
        self._power: tuple[np.ndarray, int] | None = None
        self._energy: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        """Frames in the excerpt."""
        return int(self.energy[0].size)

    @property
    def stop(self) -> int:
        """Absolute sample index just past the excerpt."""
        return self.start + int(self.x.size)

    def frame(self, t: float) -> int:
        """Excerpt frame index holding time ``t`` (seconds, absolute)."""
        return int(np.floor(t * self.sr / self.hop)) - self.f0

    def z(self, pre: int, post: int) -> np.ndarray:
        """The standardised detection function with ``pre``/``post`` frame windows."""
        key = (pre, post)
        if key not in self._z:
            n = self.n_frames
            inner = slice(min(pre, n), max(n - post, 0))
            self._z[key] = combined_z(self.energy, pre, post, self.segment, inner,
                                      FLOOR_PER_SAMPLE * self.hop)
        return self._z[key]

    def band_energy(self) -> np.ndarray:
        """Cumulative energy of the samples high-passed at :data:`BAND_HZ` (a causal filter,
        so no sound leaks ahead of its start): ``E[i]`` is the sum of the first ``i``
        squared samples, so the power over any stretch is one difference."""
        if self._energy is None:
            sos = butter_sos(4, min(BAND_HZ, 0.4 * self.sr), "highpass", self.sr)
            self._energy = np.concatenate(([0.0], np.cumsum(np.square(
                FilterStream(sos)(self.x)))))
        return self._energy

    def band_power(self) -> tuple[np.ndarray, int]:
        """Mean power above :data:`BAND_HZ` per bin of :data:`BIN_S`, bins from ``x[0]``, and
        the bin width in samples."""
        if self._power is None:
            width = max(1, round(BIN_S * self.sr))
            e = self.band_energy()[:: width]
            self._power = (np.diff(e) / width, width)
        return self._power

    def refine(self, guess: int, *, pre: int, post: int, search: int,
               search_after: int | None = None, prior: Prior | None = None,
               level: int = 0, within: tuple[int, int] | None = None) -> Refined:
        """Refine an onset near absolute sample ``guess`` (see
        :func:`~.candidates.refine_window`); the returned ``sample`` is absolute."""
        return refine_window(self.x, self.start, guess, self.sr, self.wide, self.settle,
                             pre=pre, post=post, search=search, search_after=search_after,
                             prior=prior, level=level, codec_block=self.codec_block,
                             within=within)
