"""The onset detection function: band-wise energy-rise ratios on a sub-millisecond grid.

An impact is broadband: the contact pulse, the stick's click and a fresh excitation of the
drum's modes all start at once. What is already sounding is not: hum sits at low
frequencies, a ringing head in a few modes, snare wires in a band that buzzes (modulated at the
head's fundamental). So the recording is split into a few octave-wide bands above
``highpass_hz`` (causal Butterworth filters, so no energy leaks ahead of the true onset), the
energy of each is summed on a grid of ``hop`` samples (0.5 ms or less at any sample rate), and
each band's detection function at frame ``f`` is the log ratio (dB) of its mean energy in the
``post`` frames after the frame boundary to that in the ``pre`` frames before it. The ratio
peaks where energy steps up, does not depend on the recording's level, and hovers near zero
through ring-down. Bands are combined after standardising each by its own local noise
(:mod:`drumroll.onsets.peaks`), so whichever bands are clean carry the decision.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from drumroll.onsets.dsp import LinearFilter, butter_sos
from drumroll.onsets.peaks import MAD_TO_SIGMA


@dataclass(frozen=True)
class OdfParams:
    """Settings of the detection function (times in seconds, frequencies in hertz).

    Attributes
    ----------
    hop_s
        Upper bound on the frame spacing; the hop is the largest whole number of samples
        not exceeding it.
    highpass_hz
        Lowest frequency analysed: below it are hum and rumble, not impacts.
    band_ratio
        Width of each analysis band (upper / lower edge); bands tile ``highpass_hz`` to
        0.45 of the sample rate.
    post_s, pre_s
        Lengths of the windows after and before each frame boundary whose energies are
        compared: ``post`` spans the start of an impact's sound, ``pre`` is longer for a
        steadier reference (and covers a few periods of any buzz or beating).
    """

    hop_s: float = 0.0005
    highpass_hz: float = 150.0
    band_ratio: float = 3.0
    post_s: float = 0.005
    pre_s: float = 0.010

    def hop(self, sample_rate: int) -> int:
        """Frame spacing in samples."""
        return max(1, int(np.floor(self.hop_s * sample_rate + 1e-9)))

    def frames(self, seconds: float, sample_rate: int) -> int:
        """A duration in whole frames (at least one)."""
        return max(1, round(seconds * sample_rate / self.hop(sample_rate)))


def highest_highpass(sample_rate: int) -> float:
    """The highest ``highpass_hz`` a recording at ``sample_rate`` allows: a tenth of the
    rate, so that bands are left between it and the top band's 0.45 of the rate."""
    return 0.1 * sample_rate


def band_edges(params: OdfParams, sample_rate: int) -> list[tuple[float, float | None]]:
    """Analysis bands ``(low, high)``; the top band is a high-pass (``high`` is None)."""
    top = 0.45 * sample_rate
    lo = min(params.highpass_hz, highest_highpass(sample_rate))
    edges = [lo]
    while edges[-1] * params.band_ratio < top / 1.5:
        edges.append(edges[-1] * params.band_ratio)
    return [*pairwise(edges), (edges[-1], None)]


class FilterStream:
    """Filter consecutive blocks as if they were one signal (the filter state is carried)."""

    def __init__(self, sos: np.ndarray) -> None:
        self.sos = sos
        self.filter = _linear_filter(sos.tobytes(), sos.shape[0])
        self.zi = np.zeros(self.filter.order)

    def __call__(self, block: np.ndarray) -> np.ndarray:
        out, self.zi = self.filter.filter(block, self.zi)
        return out


@functools.lru_cache(maxsize=32)
def _linear_filter(coefficients: bytes, sections: int) -> LinearFilter:
    """The block form of a filter (built once per design: every roll's excerpt runs the
    same filters again)."""
    return LinearFilter(np.frombuffer(coefficients, dtype=np.float64).reshape(sections, 6))


def band_filters(params: OdfParams, sample_rate: int) -> list[FilterStream]:
    """One streaming Butterworth filter per analysis band (2nd order: cheap, and steep
    enough since neighbouring bands only need to differ, not to be disjoint)."""
    return [FilterStream(sos.copy()) for sos in _band_sos(params, sample_rate)]


@functools.lru_cache(maxsize=16)
def _band_sos(params: OdfParams, sample_rate: int) -> tuple[np.ndarray, ...]:
    """The band filters' coefficients (designed once per setting: every roll's excerpt
    filters its audio with them again)."""
    out = []
    for lo, hi in band_edges(params, sample_rate):
        if hi is None:
            sos = butter_sos(2, lo, "highpass", sample_rate)
        else:
            sos = butter_sos(2, [lo, hi], "bandpass", sample_rate)
        out.append(sos)
    return tuple(out)


def wide_filter(params: OdfParams, sample_rate: int) -> FilterStream:
    """The high-pass (4th order) whose output the onsets are refined on."""
    return FilterStream(_wide_sos(params, sample_rate).copy())


@functools.lru_cache(maxsize=16)
def _wide_sos(params: OdfParams, sample_rate: int) -> np.ndarray:
    lo = min(params.highpass_hz, highest_highpass(sample_rate))
    return butter_sos(4, lo, "highpass", sample_rate)


def frame_energy(y: np.ndarray, hop: int) -> np.ndarray:
    """Sum of ``y**2`` over consecutive frames of ``hop`` samples (a partial tail is dropped)."""
    n = y.size // hop
    return np.einsum("ij,ij->i", y[: n * hop].reshape(n, hop), y[: n * hop].reshape(n, hop))


def rise_ratio_db(energy: np.ndarray, pre: int, post: int, floor: float) -> np.ndarray:
    """Detection function: dB ratio of mean energy after to before each frame boundary.

    Parameters
    ----------
    energy
        Per-frame energies.
    pre, post
        Window lengths in frames.
    floor
        Added to both means so that digital silence gives 0 dB rather than 0/0.

    Returns
    -------
    numpy.ndarray
        Same length as ``energy``; frames without a full window on both sides are 0.
    """
    c = np.concatenate(([0.0], np.cumsum(energy)))
    n = energy.size
    out = np.zeros(n)
    f = np.arange(pre, n - post + 1)
    if f.size == 0:
        return out
    after = (c[f + post] - c[f]) / post
    before = (c[f] - c[f - pre]) / pre
    out[f] = 10.0 * np.log10((after + floor) / (before + floor))
    return out


#: Seconds of white noise the detection function's spread on noise is measured on, and its
#: seed.
_NOISE_S, _NOISE_SEED = 4.0, 20261206


@functools.lru_cache(maxsize=64)
def noise_spreads(params: OdfParams, sample_rate: int, pre: int, post: int
                  ) -> tuple[tuple[float, ...], float]:
    """Each band's spread (a Gaussian sigma from the MAD, dB) of :func:`rise_ratio_db` on
    white Gaussian noise, and the spread there of the bands' standardised rises summed
    (:func:`~drumroll.onsets.candidates.combined_z` before its own standardisation): how
    much the detection function fluctuates where a band holds nothing but noise.

    An energy summed over a window of a band-limited noise is a chi-square of about twice
    the band's time-bandwidth product in degrees of freedom, so the ratio of two such sums
    scatters by a spread set by the band and the windows alone, whatever the level. A sound
    decaying smoothly (a pure tone dying away, as a synthesised or a metal bouncer's can)
    makes the ratio far steadier than that; standardised by its own spread, the noise it
    decays into reads as rises (damped 3 kHz tones at 40 dB: ten "candidates" within 60 ms
    after one of them, which the tracker followed as a roll of their own, splitting the true
    roll and losing its two loudest impacts). Where a band, or the sum, is that steady, it is
    judged by this spread instead (:data:`~drumroll.onsets.peaks.STEADY`). Measured once per
    setting, on the same filters and windows (seeded: the same every run), one value per
    ``post // 2`` frames as the statistics take them, past the filters' start.
    """
    rng = np.random.default_rng(_NOISE_SEED)
    hop = params.hop(sample_rate)
    x = rng.standard_normal(int(_NOISE_S * sample_rate))
    stride, settle = max(1, post // 2), 4 * (pre + post)
    bands, total = [], 0.0
    for filt in band_filters(params, sample_rate):
        energy = frame_energy(filt(x), hop)
        ratio = rise_ratio_db(energy, pre, post, 0.0)[settle: energy.size - post: stride]
        centre = np.median(ratio)
        bands.append(_robust_sigma(ratio, centre))
        total = total + np.maximum((ratio - centre) / bands[-1], 0.0)
    return tuple(bands), _robust_sigma(total, np.median(total))


def _robust_sigma(values: np.ndarray, centre: float) -> float:
    """The MAD of ``values`` about ``centre``, as a Gaussian sigma."""
    return float(MAD_TO_SIGMA * np.median(np.abs(values - centre)))
