"""The onset detection function: a high-frequency energy-rise ratio on a sub-millisecond grid.

An impact is a click: broadband, with most of its contrast against the drum's ring and the
room's hum at high frequencies. The recording is high-passed (a causal Butterworth filter,
so no energy leaks ahead of the true onset), its energy is summed on a grid of ``hop``
samples (0.5 ms or less at any sample rate), and the detection function at frame ``f`` is the
log ratio (dB) of the mean energy in the ``post`` frames after the frame boundary to the mean
energy in the ``pre`` frames before it. This ratio peaks where the energy steps up, does not
depend on the recording's level, and stays near zero (slightly negative) through ring-down.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal


@dataclass(frozen=True)
class OdfParams:
    """Settings of the detection function (times in seconds, frequencies in hertz).

    Attributes
    ----------
    hop_s
        Upper bound on the frame spacing; the hop is the largest whole number of samples
        not exceeding it.
    highpass_hz
        Corner of the high-pass that isolates the click; capped at a quarter of the sample
        rate. Lower it for impacts with little high-frequency content (soft balls).
    post_s, pre_s
        Lengths of the windows after and before each frame boundary whose energies are
        compared: ``post`` about one click long, ``pre`` longer for a steadier reference.
    """

    hop_s: float = 0.0005
    highpass_hz: float = 2000.0
    post_s: float = 0.002
    pre_s: float = 0.004

    def hop(self, sample_rate: int) -> int:
        """Frame spacing in samples."""
        return max(1, int(np.floor(self.hop_s * sample_rate + 1e-9)))

    def frames(self, seconds: float, sample_rate: int) -> int:
        """A duration in whole frames (at least one)."""
        return max(1, round(seconds * sample_rate / self.hop(sample_rate)))


def highpass(params: OdfParams, sample_rate: int) -> np.ndarray:
    """Second-order sections of the click-isolating high-pass (4th-order Butterworth)."""
    corner = min(params.highpass_hz, 0.25 * sample_rate)
    return signal.butter(4, corner, btype="highpass", fs=sample_rate, output="sos")


class HighpassStream:
    """Filter consecutive blocks as if they were one signal (the filter state is carried)."""

    def __init__(self, params: OdfParams, sample_rate: int) -> None:
        self.sos = highpass(params, sample_rate)
        self.zi = np.zeros((self.sos.shape[0], 2))

    def __call__(self, block: np.ndarray) -> np.ndarray:
        out, self.zi = signal.sosfilt(self.sos, block, zi=self.zi)
        return out


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
