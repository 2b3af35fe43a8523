"""Streaming candidate extraction: detection function, adaptive picking and refinement.

Audio arrives in blocks of any size. High-passed samples are kept only for a few seconds
around the frames being decided, so memory stays bounded however long the recording is:
an hour costs what a minute costs. Every candidate leaves with a sample-accurate time and its
own uncertainty; deciding which candidates are bounces is :mod:`drumroll.onsets.tracking`'s
job.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from drumroll.onsets.odf import HighpassStream, OdfParams, frame_energy, rise_ratio_db
from drumroll.onsets.peaks import local_maxima, robust_z
from drumroll.onsets.refine import refine_onset

#: Energy floor per sample (about -140 dBFS) so digital silence has a defined ratio.
_FLOOR_PER_SAMPLE = 1e-14


@dataclass
class Candidates:
    """Possible impacts, in time order (parallel arrays)."""

    time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    z: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rise_db: np.ndarray = field(default_factory=lambda: np.zeros(0))
    amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))
    snr_db: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sigma_s: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return int(self.time_s.size)

    def subset(self, index: np.ndarray) -> Candidates:
        """The candidates at ``index``."""
        return Candidates(*(getattr(self, n)[index] for n in _FIELDS))


_FIELDS = ("time_s", "z", "rise_db", "amplitude", "snr_db", "sigma_s")


class CandidateStream:
    """Feed blocks with :meth:`feed`, then call :meth:`finish` to get the candidates.

    Parameters
    ----------
    sample_rate
        Of the audio fed.
    params
        Detection-function settings.
    threshold
        Significance (robust standard deviations of the detection function above its median)
        a frame must reach to become a candidate.
    stats_s
        Half-width of the window whose median and MAD standardise the detection function.
    """

    def __init__(self, sample_rate: int, params: OdfParams = OdfParams(), *,
                 threshold: float = 5.0, stats_s: float = 1.0) -> None:
        self.sr = int(sample_rate)
        self.params = params
        self.threshold = float(threshold)
        self.hop = params.hop(self.sr)
        self.pre = params.frames(params.pre_s, self.sr)
        self.post = params.frames(params.post_s, self.sr)
        # Candidates at least 1 ms apart: closer peaks are one click's fine structure.
        self.half_width = params.frames(0.001, self.sr)
        self.context = max(params.frames(stats_s, self.sr), 4 * (self.pre + self.post))
        self.chunk = self.context
        self.hp = HighpassStream(params, self.sr)
        self.buf = np.zeros(0)
        self.buf0 = 0  # absolute sample index of buf[0]; always a multiple of hop
        self.done = 0  # frames before this one have been decided
        self.total = 0  # samples fed so far
        self.peak = 0.0
        self._parts: list[tuple[np.ndarray, ...]] = []

    def feed(self, block: np.ndarray) -> None:
        """Add the next block of (mono) samples."""
        block = np.asarray(block, dtype=np.float64)
        if block.size == 0:
            return
        self.total += block.size
        self.peak = max(self.peak, float(np.abs(block).max()))
        self.buf = np.concatenate((self.buf, self.hp(block)))
        while (self.buf0 + self.buf.size) // self.hop >= self.done + self.chunk + self.context:
            self._decide(self.done + self.chunk)

    def finish(self) -> Candidates:
        """Decide the remaining frames and return every candidate found."""
        # Pad with silence so the last click still has a full window after it.
        pad = (self.post + self.half_width + 2) * self.hop
        self.buf = np.concatenate((self.buf, np.zeros(pad)))
        end = self.total // self.hop + 1
        while self.done < end:
            self._decide(min(self.done + self.chunk, end))
        if not self._parts:
            return Candidates()
        return Candidates(*(np.concatenate(col) for col in zip(*self._parts, strict=True)))

    def _decide(self, stop: int) -> None:
        """Pick candidates in frames ``[done, stop)`` using the context around them."""
        hop = self.hop
        lo = max(self.done - self.context, self.buf0 // hop)
        hi = min(stop + self.context, (self.buf0 + self.buf.size) // hop)
        y = self.buf[lo * hop - self.buf0: hi * hop - self.buf0]
        energy = frame_energy(y, hop)
        odf = rise_ratio_db(energy, self.pre, self.post, _FLOOR_PER_SAMPLE * hop)
        inner = slice(min(self.pre, odf.size), max(odf.size - self.post, 0))
        z, _, _ = robust_z(odf, inner)
        peaks = local_maxima(z, self.threshold, self.half_width)
        peaks = peaks[(peaks + lo >= self.done) & (peaks + lo < stop)]
        rows = []
        for f in peaks:
            r = refine_onset(y, int(f) * hop, self.sr, pre=self.pre * hop,
                             post=self.post * hop, search=3 * hop)
            rows.append(((lo * hop + r.sample) / self.sr, z[f], odf[f], r.amplitude,
                         r.snr_db, r.sigma_s))
        if rows:
            self._parts.append(tuple(np.asarray(c, dtype=float) for c in zip(*rows,
                                                                            strict=True)))
        self.done = stop
        # Keep only the context the next decision needs.
        keep_from = max(self.done - self.context, 0) * hop
        if keep_from > self.buf0:
            self.buf = self.buf[keep_from - self.buf0:]
            self.buf0 = keep_from
