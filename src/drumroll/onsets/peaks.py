"""Adaptive peak picking on the detection function.

The threshold is not a level but a significance: the detection function is standardised by
its own robust statistics (median and MAD, scaled to a Gaussian sigma) over a few seconds
around each frame, so the same setting works for a whisper-quiet ball and a loud snare, and
for steady noise as well as for the fluctuating ring-down inside a roll.
"""

from __future__ import annotations

import warnings

import numpy as np

from drumroll.onsets.dsp import maximum_filter1d, median_filter1d

#: MAD to Gaussian standard deviation.
MAD_TO_SIGMA = 1.4826
#: A detection function whose local spread is under this fraction of its spread on noise
#: alone is holding a sound that decays smoothly (a pure tone dying away), not noise: noise's
#: own spread, estimated over a segment of a few hundred frames, never falls that far under
#: its value. Between this and noise's spread a band holds a drum's ring, partly noise-like,
#: and is standardised by its own spread, as the extractor always has (bounding those too
#: finds the first impact of all 288 tone rolls of benchmarks/foreign_sounds.py where this
#: finds it in 281 and the old rule in 270, but moves onsets of the bundled recordings and
#: loses faint bounces of drumroll's own simulated rolls).
STEADY = 0.3


def local_maxima(z: np.ndarray, threshold: float, half_width: int) -> np.ndarray:
    """Frames where ``z`` is at least ``threshold`` and the largest within ``±half_width``.

    Plateaus keep their first frame only.
    """
    if z.size == 0:
        return np.zeros(0, dtype=np.int64)
    biggest = maximum_filter1d(z, 2 * half_width + 1)
    idx = np.flatnonzero((z >= threshold) & (z >= biggest))
    if idx.size > 1:  # drop later frames of a flat top
        keep = np.concatenate(([True], np.diff(idx) > half_width))
        idx = idx[keep]
    return idx


def local_robust_z(odf: np.ndarray, segment: int, reach: int = 3,
                   valid: slice | None = None, stride: int = 1,
                   noise_sigma: float = 0.0, silent: np.ndarray | None = None) -> np.ndarray:
    """Standardise ``odf`` by a slowly varying median and MAD.

    The median and MAD are taken over segments of ``segment`` frames, then smoothed by a
    running median over ``±reach`` segments, so a loud passage (the roll itself) sets its
    own scale without letting the few frames of any one impact inflate it.

    Parameters
    ----------
    odf
        Detection function.
    segment
        Frames per segment.
    reach
        Segments either side in the running median.
    valid
        Frames whose values are meaningful (the rest are ignored in the statistics).
    stride
        Use every ``stride``-th frame for the statistics: a detection function computed over
        windows of several frames is strongly correlated from frame to frame, so thinning it
        to about one value per window loses little and saves most of the sorting.
    noise_sigma
        The spread ``odf`` has on noise alone (0: not known). Where the local spread is
        under :data:`STEADY` of it, the frames are standardised by it instead: after a smooth
        decay, the noise it decays into is judged as noise, not against the decay's
        steadiness (it would read as rises, candidates the tracker can follow as a roll).
    silent
        Frames (a mask over ``odf``) that measured nothing: both of the detection function's
        windows in digital silence, exact zeros that no microphone gives (a recorder's
        buffer before it captured, an editor's padding, a noise gate shut). They are left
        out of the statistics: counted in, a stretch of them makes a segment's median 0 and
        its MAD a fraction of the noise's, so the noise just after the silence, measured by
        that, stands out as a run of impacts.
    """
    ref = odf if valid is None else odf[valid]
    offset = 0 if valid is None else (valid.start or 0)
    if ref.size == 0:
        return np.zeros_like(odf)
    skip = None
    if silent is not None:
        skip = silent if valid is None else silent[valid]
        skip = skip if skip.any() else None
    n_full, rest = divmod(ref.size, segment)
    med, mad = [], []
    if skip is not None:  # the rare file with digital silence: NaN-aware statistics
        ref = np.where(skip, np.nan, ref)
    median = np.median if skip is None else _nan_median
    if n_full:  # all whole segments at once (no per-segment Python loop)
        blocks = ref[: n_full * segment].reshape(n_full, segment)[:, ::max(stride, 1)]
        m = median(blocks, axis=1)
        med.append(m)
        mad.append(median(np.abs(blocks - m[:, None]), axis=1))
    if rest:
        part = ref[n_full * segment:]
        m_last = float(median(part))
        med.append(np.array([m_last]))
        mad.append(np.array([median(np.abs(part - m_last))]))
    med_a, mad_a = np.concatenate(med), np.concatenate(mad)
    if skip is not None:
        med_a, mad_a = _from_nearest_measured(med_a), _from_nearest_measured(mad_a)
    n_seg = med_a.size
    if n_seg > 1:
        med_a = median_filter1d(med_a, 2 * reach + 1)
        mad_a = median_filter1d(mad_a, 2 * reach + 1)
    sigma = MAD_TO_SIGMA * mad_a
    sigma = np.where(sigma < STEADY * noise_sigma, noise_sigma, np.maximum(sigma, 1e-3))
    seg_of = np.clip((np.arange(odf.size) - offset) // segment, 0, n_seg - 1)
    return (odf - med_a[seg_of]) / sigma[seg_of]


def _nan_median(x: np.ndarray, axis: int | None = None) -> np.ndarray:
    """``np.nanmedian``, NaN (without a warning) where a slice holds only NaN."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmedian(x, axis=axis)


def _from_nearest_measured(values: np.ndarray) -> np.ndarray:
    """Segments' statistics with those of segments that measured nothing (NaN: all silent)
    taken from the nearest segment that did; 0 where none did (the spread then falls back to
    noise's, :data:`STEADY`)."""
    measured = np.flatnonzero(np.isfinite(values))
    if measured.size == values.size:
        return values
    if measured.size == 0:
        return np.zeros_like(values)
    at = np.arange(values.size)
    right = np.clip(np.searchsorted(measured, at), 0, measured.size - 1)
    left = np.clip(right - 1, 0, measured.size - 1)
    nearest = np.where(np.abs(measured[left] - at) <= np.abs(measured[right] - at),
                       measured[left], measured[right])
    return values[nearest]
