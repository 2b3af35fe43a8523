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

from drumroll.onsets.dsp import LinearFilter, sos_poles
from drumroll.onsets.odf import (
    OdfParams,
    band_filters,
    frame_energy,
    noise_spreads,
    rise_ratio_db,
    wide_filter,
)
from drumroll.onsets.peaks import local_maxima, local_robust_z
from drumroll.onsets.refine import Prior, Refined, refine_onset

#: Energy floor per sample (about -140 dBFS) so digital silence has a defined ratio.
FLOOR_PER_SAMPLE = 1e-14


@dataclass
class Candidates:
    """Possible impacts, in time order (parallel arrays)."""

    time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    z: np.ndarray = field(default_factory=lambda: np.zeros(0))
    level: np.ndarray = field(default_factory=lambda: np.zeros(0))
    amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))
    snr_db: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sigma_s: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return int(self.time_s.size)

    def subset(self, index: np.ndarray) -> Candidates:
        """The candidates at ``index``."""
        return Candidates(*(getattr(self, n)[index] for n in _FIELDS))


_FIELDS = ("time_s", "z", "level", "amplitude", "snr_db", "sigma_s")


def combined_z(energies: list[np.ndarray], pre: int, post: int, segment: int,
               inner: slice, floor: float,
               spreads: tuple[tuple[float, ...], float] | None = None) -> np.ndarray:
    """The standardised multi-band detection function of consecutive frames.

    Each band's rise ratio (:func:`~.odf.rise_ratio_db`) is standardised by its own local
    median and MAD; the positive parts (only rises count: a band falling silent says nothing
    about an impact) are summed and standardised again.

    Parameters
    ----------
    energies
        Per-band frame energies over the same frames.
    pre, post
        Window lengths of the rise ratio, frames.
    segment
        Frames per segment of the local statistics (:func:`~.peaks.local_robust_z`).
    inner
        Frames with a full window on both sides (the statistics use only these).
    floor
        Energy floor per frame.
    spreads
        The spreads each band's rise ratio (dB) and their sum have on noise alone
        (:func:`~.odf.noise_spreads`), which stand in for a spread far steadier than that
        (:data:`~.peaks.STEADY`); none by default.
    """
    combined = np.zeros(energies[0].size)
    stride = max(1, post // 2)  # the ratio is a moving window: neighbours are alike
    bands, total = spreads if spreads is not None else ((0.0,) * len(energies), 0.0)
    silent = digital_silence(energies, pre, post)
    for energy, spread in zip(energies, bands, strict=True):
        odf = rise_ratio_db(energy, pre, post, floor)
        combined += np.maximum(local_robust_z(odf, segment, valid=inner, stride=stride,
                                              noise_sigma=spread, silent=silent), 0.0)
    return local_robust_z(combined, segment, valid=inner, stride=stride, noise_sigma=total,
                          silent=silent)


def digital_silence(energies: list[np.ndarray], pre: int, post: int) -> np.ndarray:
    """Frames whose detection-function windows (``pre`` frames before, ``post`` after) hold
    only exact zeros in every band: the rise ratio there is the floor's over itself, 0 dB by
    construction, not a measurement (:func:`~.peaks.local_robust_z` leaves them out)."""
    total = np.sum(energies, axis=0)
    c = np.concatenate(([0], np.cumsum(total > 0.0)))
    n = total.size
    silent = np.zeros(n, dtype=bool)
    f = np.arange(pre, n - post + 1)
    silent[f] = c[f + post] - c[f - pre] == 0
    return silent


def plateau(z: np.ndarray, f: int, reach: int, within: float = 1.0) -> tuple[int, int]:
    """The frames around the peak ``f`` (at most ``reach`` either side) over which ``z``
    stays within ``within`` of the peak (z is standardised: that is its own noise scale).

    Where on such a plateau noise puts the maximum is chance: a short click gives a plateau
    that ends at its onset (the window after each earlier frame boundary already holds all of
    it), a faint or slowly building impact one that starts near its onset. So the onset is
    searched for over the whole plateau.
    """
    level = z[f] - within
    a = f
    while a > max(f - reach, 0) and z[a - 1] >= level:
        a -= 1
    b = f
    while b < min(f + reach, z.size - 1) and z[b + 1] >= level:
        b += 1
    return a, b


def settle_samples(sos: np.ndarray, sample_rate: int, efolds: float = 14.0) -> int:
    """Samples after which a filter started from rest has forgotten its start (its slowest
    pole has decayed by ``efolds`` e-folds, about -120 dB for 14)."""
    poles = sos_poles(sos)
    slowest = float(np.max(np.abs(poles)))
    if slowest <= 0.0:
        return 1
    return int(np.ceil(efolds / max(-np.log(slowest), 1e-9)))


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
    codec_block
        For a lossy file, the stretch (samples) its codec may spread noise ahead of an
        impact by (:func:`~.refine.out_of_codec_noise`); 0 for lossless audio.

    Notes
    -----
    Frames are decided in chunks of a few seconds, each with ``stats_s`` of context on either
    side. Only the band filters run over every sample; the wide high-pass the onsets are
    refined on is run from rest over a short window before each candidate (long enough for
    the filter to settle), so results do not depend on how the audio is blocked.
    """

    def __init__(self, sample_rate: int, params: OdfParams | None = None, *,
                 threshold: float = 5.0, stats_s: float = 1.0, refine_pre_s: float = 0.008,
                 refine_post_s: float = 0.002, refine_search_s: float = 0.002,
                 refine_after_s: float = 0.002, codec_block: int = 0) -> None:
        self.sr = int(sample_rate)
        self.codec_block = int(codec_block)
        self.params = params = params or OdfParams()
        self.threshold = float(threshold)
        self.hop = params.hop(self.sr)
        self.pre = params.frames(params.pre_s, self.sr)
        self.post = params.frames(params.post_s, self.sr)
        self.post_loc = params.frames(0.001, self.sr)
        # Candidates at least 1 ms apart: closer peaks are one click's fine structure.
        self.half_width = params.frames(0.001, self.sr)
        self.context = max(params.frames(stats_s, self.sr), 4 * (self.pre + self.post))
        self.chunk = 8 * self.context
        self.segment = params.frames(0.25, self.sr)
        self.ref_pre = round(refine_pre_s * self.sr)
        self.ref_post = max(2, round(refine_post_s * self.sr))
        self.ref_search = max(2, round(refine_search_s * self.sr))
        self.ref_after = max(2, round(refine_after_s * self.sr))
        wide = wide_filter(params, self.sr)
        self.settle = settle_samples(wide.sos, self.sr)
        self.wide = wide.filter
        self.bands = band_filters(params, self.sr)
        # Per-band frame energies from ``buf0 // hop`` on, and samples not yet in a frame.
        self.energy = [np.zeros(0) for _ in self.bands]
        self.tails = [np.zeros(0) for _ in self.bands]
        self.buf = np.zeros(0)  # raw samples from buf0 on
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
        return _merge_close(c, self.post * self.hop / self.sr)

    def _add(self, block: np.ndarray) -> None:
        self.buf = np.concatenate((self.buf, block))
        for b, filt in enumerate(self.bands):
            y = filt(block)
            if self.tails[b].size:
                y = np.concatenate((self.tails[b], y))
            e = frame_energy(y, self.hop)
            self.tails[b] = y[e.size * self.hop:]
            self.energy[b] = np.concatenate((self.energy[b], e))

    def _decide(self, stop: int) -> None:
        """Pick candidates in frames ``[done, stop)`` using the context around them."""
        hop = self.hop
        f0 = self.buf0 // hop
        lo = max(self.done - self.context, f0)
        hi = min(stop + self.context, f0 + min(e.size for e in self.energy))
        inner = slice(min(self.pre, hi - lo), max(hi - lo - self.post, 0))
        energies = [e[lo - f0: hi - f0] for e in self.energy]
        # Whether a frame is a candidate is decided with a band far steadier than noise
        # judged by noise's spread (peaks.STEADY). The short-window function that places a
        # candidate on its rise (below) and the stages' own (excerpt.Excerpt.z) are
        # standardised as before: they compare frames near a sound, not a sound with noise.
        z = combined_z(energies, self.pre, self.post, self.segment, inner,
                       FLOOR_PER_SAMPLE * hop,
                       noise_spreads(self.params, self.sr, self.pre, self.post))
        peaks = local_maxima(z, self.threshold, self.half_width)
        peaks = peaks[(peaks + lo >= self.done) & (peaks + lo < stop)]
        rows = []
        if peaks.size:
            # Where on a plateau the energy stepped up: the detection function with a window
            # too short to plateau before a click (only used to locate, never to detect).
            z_loc = combined_z(energies, self.pre, self.post_loc, self.segment, inner,
                               FLOOR_PER_SAMPLE * hop)
            for f in peaks.tolist():
                first, last = plateau(z, f, self.post)
                g = max(first - self.post_loc, 0)
                at = g + int(np.argmax(z_loc[g: last + 1]))
                rows.append((*self._refine((lo + at) * hop, (at - first) * hop), z[f]))
        if rows:
            cols = list(zip(*rows, strict=True))
            # Candidates columns: time, z, level, amplitude, snr, sigma.
            self._parts.append(tuple(np.asarray(cols[i], dtype=float)
                                     for i in (0, 5, 4, 1, 2, 3)))
        self.done = stop
        # Keep only the context the next decision needs.
        keep_from = max(self.done - self.context, 0) * hop
        if keep_from > self.buf0:
            drop = (keep_from - self.buf0) // hop
            self.buf = self.buf[keep_from - self.buf0:]
            self.energy = [e[drop:] for e in self.energy]
            self.buf0 = keep_from

    def _refine(self, guess: int, lead: int) -> tuple[float, float, float, float, float]:
        """Refine an onset near absolute sample ``guess``, whose detection plateau starts
        ``lead`` samples earlier: time, amplitude, SNR, sigma and level (the peak over the
        detection function's window after the onset)."""
        back = self.ref_search + max(lead, 0)
        r = refine_window(self.buf, self.buf0, guess, self.sr, self.wide, self.settle,
                          pre=self.ref_pre + back - self.ref_search, post=self.ref_post,
                          search=back,
                          search_after=self.ref_after, level=self.post * self.hop,
                          codec_block=self.codec_block)
        return r.sample / self.sr, r.amplitude, r.snr_db, r.sigma_s, r.level


def refine_window(buf: np.ndarray, buf0: int, guess: int, sample_rate: int,
                  highpass: LinearFilter, settle: int, *, pre: int, post: int,
                  search: int, search_after: int | None = None, level: int = 0,
                  prior: Prior | None = None, codec_block: int = 0,
                  within: tuple[int, int] | None = None) -> Refined:
    """Refine an onset near absolute sample ``guess`` of raw samples ``buf`` (``buf[0]`` is
    absolute sample ``buf0``): the wide high-pass (its cascade of sections) is run from rest
    ``settle`` samples before the refinement window. Returns the refined onset with an
    absolute ``sample`` and, if ``level`` > 0, the peak of the high-passed sound over
    ``level`` samples from it. ``prior`` (optional) is in absolute samples; ``codec_block``
    is the stretch a lossy codec's noise may precede a sound by
    (:func:`~.refine.out_of_codec_noise`; 0: lossless); ``within`` (optional, absolute
    samples) narrows where the onset may land (:func:`~.refine.refine_onset`)."""
    a = max(guess - pre - settle, 0)
    after = search if search_after is None else search_after
    b = guess + max(post + codec_block, after + level)
    x = buf[max(a - buf0, 0): max(b - buf0, 0)]
    lead = max(buf0 - a, 0)
    if lead:  # before the buffer (only at the file's start): silence
        x = np.concatenate((np.zeros(lead), x))
    if x.size < b - a:
        x = np.concatenate((x, np.zeros(b - a - x.size)))
    y = highpass.filter(x)[0]
    r = refine_onset(y, guess - a, sample_rate, pre=pre, post=post, search=search,
                     search_after=search_after,
                     prior=None if prior is None else prior.shifted(-a),
                     codec_block=codec_block,
                     within=None if within is None else (within[0] - a, within[1] - a))
    peak = float(np.abs(y[r.sample: r.sample + level]).max()) if level > 0 else float("nan")
    return Refined(r.sample + a, r.amplitude, r.snr_db, r.sigma_s, r.rise_s, peak,
                   r.raw_snr_db)


def _merge_close(c: Candidates, gap_s: float) -> Candidates:
    """Merge candidates that refined to within ``gap_s`` of the one before them.

    Two peaks of the detection function that close belong to one sound as far as this
    detection function can tell (the later one is measured against a reference that holds
    the earlier one): a faint impact's energy often arrives in two steps (the click, then the
    drum and the snare wires building up). The sound starts at the earlier one, so its time
    is kept, with the larger significance of the two.
    """
    order = np.argsort(c.time_s, kind="stable")
    c = c.subset(order)
    keep = np.ones(len(c), dtype=bool)
    z = c.z.copy()
    last = -1
    for i in range(len(c)):
        if last >= 0 and c.time_s[i] - c.time_s[last] < gap_s:
            keep[i] = False
            z[last] = max(z[last], z[i])
        else:
            last = i
    c.z = z
    return c.subset(np.flatnonzero(keep))
