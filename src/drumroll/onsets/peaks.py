"""Adaptive peak picking on the detection function.

The threshold is not a level but a significance: the detection function is standardised by
its own robust statistics (median and MAD, scaled to a Gaussian sigma) over a few seconds
around each frame, so the same setting works for a whisper-quiet ball and a loud snare, and
for steady noise as well as for the fluctuating ring-down inside a roll.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

#: MAD to Gaussian standard deviation.
MAD_TO_SIGMA = 1.4826


def robust_z(odf: np.ndarray, valid: slice | None = None) -> tuple[np.ndarray, float, float]:
    """Standardise ``odf`` by the median and MAD of the frames in ``valid``.

    Returns
    -------
    z, median, sigma
        ``z = (odf - median) / sigma``; ``sigma`` is never zero (a perfectly flat detection
        function, e.g. digital silence, gets a tiny positive one so nothing is significant).
    """
    ref = odf if valid is None else odf[valid]
    med = float(np.median(ref)) if ref.size else 0.0
    sigma = MAD_TO_SIGMA * float(np.median(np.abs(ref - med))) if ref.size else 0.0
    sigma = max(sigma, 1e-3)  # dB: a rise smaller than this means nothing in any recording
    return (odf - med) / sigma, med, sigma


def local_maxima(z: np.ndarray, threshold: float, half_width: int) -> np.ndarray:
    """Frames where ``z`` is at least ``threshold`` and the largest within ``±half_width``.

    Plateaus keep their first frame only.
    """
    if z.size == 0:
        return np.zeros(0, dtype=np.int64)
    biggest = ndimage.maximum_filter1d(z, size=2 * half_width + 1, mode="nearest")
    idx = np.flatnonzero((z >= threshold) & (z >= biggest))
    if idx.size > 1:  # drop later frames of a flat top
        keep = np.concatenate(([True], np.diff(idx) > half_width))
        idx = idx[keep]
    return idx
