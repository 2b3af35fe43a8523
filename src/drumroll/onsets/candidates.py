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

from drumroll.onsets.odf import (
    OdfParams,
    band_filters,
    frame_energy,
    rise_ratio_db,
    wide_filter,
)
from drumroll.onsets.peaks import local_maxima, local_robust_z
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
    refine_pre_s, refine_post_s, refine_search_s
        Windows of the sample-accurate refinement (see :func:`~.refine.refine_onset`).
    """

    def __init__(self, sample_rate: int, params: OdfParams | None = None, *,
                 threshold: float = 5.0, stats_s: float = 1.0, refine_pre_s: float = 0.008,
                 refine_post_s: float = 0.002, refine_search_s: float = 0.002) -> None:
        self.sr = int(sample_rate)
        self.params = params = params or OdfParams()
        self.threshold = float(threshold)
        self.hop = params.hop(self.sr)
        self.pre = params.frames(params.pre_s, self.sr)
        self.post = params.frames(params.post_s, self.sr)
        # Candidates at least 1 ms apart: closer peaks are one click's fine structure.
        self.half_width = params.frames(0.001, self.sr)
        self.context = max(params.frames(stats_s, self.sr), 4 * (self.pre + self.post))
        self.chunk = self.context
        self.segment = params.frames(0.25, self.sr)
        self.ref_pre = round(refine_pre_s * self.sr)
        self.ref_post = max(2, round(refine_post_s * self.sr))
        self.ref_search = max(2, round(refine_search_s * self.sr))
        self.wide = wide_filter(params, self.sr)
        self.bands = band_filters(params, self.sr)
        # Per-band frame energies from ``buf0 // hop`` on, and samples not yet in a frame.
        self.energy = [np.zeros(0) for _ in self.bands]
        self.tails = [np.zeros(0) for _ in self.bands]
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
        self._add(block)
        while (self.buf0 + self.buf.size) // self.hop >= self.done + self.chunk + self.context:
            self._decide(self.done + self.chunk)

    def finish(self) -> Candidates:
        """Decide the remaining frames and return every candidate found."""
        # Pad with silence so the last click still has a full window after it.
        pad = (self.post + self.half_width + 2) * self.hop
        self._add(np.zeros(pad))
        end = self.total // self.hop + 1
        while self.done < end:
            self._decide(min(self.done + self.chunk, end))
        if not self._parts:
            return Candidates()
        c = Candidates(*(np.concatenate(col) for col in zip(*self._parts, strict=True)))
        return _merge_close(c, self.half_width * self.hop / self.sr)

    def _add(self, block: np.ndarray) -> None:
        self.buf = np.concatenate((self.buf, self.wide(block)))
        for b, filt in enumerate(self.bands):
            y = np.concatenate((self.tails[b], filt(block)))
            e = frame_energy(y, self.hop)
            self.tails[b] = y[e.size * self.hop:]
            self.energy[b] = np.concatenate((self.energy[b], e))

    def _decide(self, stop: int) -> None:
        """Pick candidates in frames ``[done, stop)`` using the context around them."""
        hop = self.hop
        lo = max(self.done - self.context, self.buf0 // hop)
        hi = min(stop + self.context, (self.buf0 + self.buf.size) // hop)
        y = self.buf[lo * hop - self.buf0: hi * hop - self.buf0]
        f0 = self.buf0 // hop
        inner = slice(min(self.pre, hi - lo), max(hi - lo - self.post, 0))
        combined = np.zeros(hi - lo)
        for energy in self.energy:
            odf = rise_ratio_db(energy[lo - f0: hi - f0], self.pre, self.post,
                                _FLOOR_PER_SAMPLE * hop)
            # Only rises count: a band falling silent says nothing about an impact.
            combined += np.maximum(local_robust_z(odf, self.segment, valid=inner), 0.0)
        z = local_robust_z(combined, self.segment, valid=inner)
        odf = combined
        peaks = local_maxima(z, self.threshold, self.half_width)
        peaks = peaks[(peaks + lo >= self.done) & (peaks + lo < stop)]
        rows = []
        for f in peaks:
            r = refine_onset(y, int(f) * hop, self.sr, pre=self.ref_pre, post=self.ref_post,
                             search=self.ref_search)
            rows.append(((lo * hop + r.sample) / self.sr, z[f], odf[f], r.amplitude,
                         r.snr_db, r.sigma_s))
        if rows:
            self._parts.append(tuple(np.asarray(c, dtype=float) for c in zip(*rows,
                                                                            strict=True)))
        self.done = stop
        # Keep only the context the next decision needs.
        keep_from = max(self.done - self.context, 0) * hop
        if keep_from > self.buf0:
            drop = (keep_from - self.buf0) // hop
            self.buf = self.buf[keep_from - self.buf0:]
            self.energy = [e[drop:] for e in self.energy]
            self.buf0 = keep_from


def _merge_close(c: Candidates, gap_s: float) -> Candidates:
    """Keep one candidate (the most significant) of any that refined to within ``gap_s``:
    two peaks of the detection function can belong to one sound."""
    order = np.argsort(c.time_s, kind="stable")
    c = c.subset(order)
    keep = np.ones(len(c), dtype=bool)
    last = -1
    for i in range(len(c)):
        if last >= 0 and c.time_s[i] - c.time_s[last] < gap_s:
            if c.z[i] > c.z[last]:
                keep[last] = False
                last = i
            else:
                keep[i] = False
        else:
            last = i
    return c.subset(np.flatnonzero(keep))
