"""Recorded sounds (drum hits, room impulse responses) read at the rendering's sample rate.

A file is read whole (these are short: a hit lasts about a second, a room response two),
mixed to mono by averaging its channels, and converted to the requested rate with
:func:`scipy.signal.resample_poly` (a polyphase FIR with a Kaiser window, applied at the
exact rational ratio of the two rates, so nothing drifts in time).
"""

from __future__ import annotations

import os
from fractions import Fraction

import numpy as np
from scipy import signal

from drumroll.audio.io import probe, read_audio
from drumroll.errors import AudioError


def is_lossy(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` holds lossy-coded audio (Vorbis, Opus, MP3, AAC, AMR, ...)."""
    return not probe(path).lossless


def read_mono(path: str | os.PathLike[str], sample_rate: int) -> np.ndarray:
    """The sound in ``path`` as mono ``float64`` at ``sample_rate``.

    Parameters
    ----------
    path
        Any recording :mod:`drumroll.audio.io` reads (WAV, FLAC, OGG, a phone's .m4a, ...).
    sample_rate
        Samples per second of the result.

    Returns
    -------
    numpy.ndarray
        1-D samples; multichannel files are averaged across channels.

    Raises
    ------
    drumroll.errors.AudioError
        One line naming the file: missing, not audio, damaged, empty, or holding NaN or
        infinite samples.
    """
    # One-line errors for missing, unreadable, damaged and empty files; a sample is not
    # checked for clipping (a hit normalised to full scale is not a clipped recording).
    mono, rate = read_audio(path, check=False)
    if mono.size == 0:
        raise AudioError(f"{path}: holds no audio (zero-length or truncated)")
    if not np.isfinite(mono).all():
        raise AudioError(f"{path}: NaN or infinite samples")
    return resample(mono, int(rate), int(sample_rate))


def resample(x: np.ndarray, rate_in: int, rate_out: int) -> np.ndarray:
    """``x`` at ``rate_in`` converted to ``rate_out`` (identity when the rates agree)."""
    if rate_in == rate_out:
        return np.array(x, dtype=float)
    ratio = Fraction(int(rate_out), int(rate_in))
    return signal.resample_poly(np.asarray(x, dtype=float), ratio.numerator, ratio.denominator)
