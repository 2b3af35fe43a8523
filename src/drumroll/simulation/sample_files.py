"""Recorded sounds (drum hits, room impulse responses) read at the rendering's sample rate.

A file is read whole (these are short: a hit lasts about a second, a room response two),
mixed to mono by averaging its channels, and converted to the requested rate with
:func:`scipy.signal.resample_poly` (a polyphase FIR with a Kaiser window, applied at the
exact rational ratio of the two rates, so nothing drifts in time).
"""

from __future__ import annotations

import os
from fractions import Fraction
from pathlib import Path

import numpy as np
import soundfile as sf
from scipy import signal

from drumroll.audio.io import probe
from drumroll.errors import AudioError

#: soundfile subtypes of lossy codecs (transform codecs: they smear noise ahead of transients).
LOSSY_SUBTYPES = frozenset({"VORBIS", "OPUS", "MPEG_LAYER_I", "MPEG_LAYER_II",
                            "MPEG_LAYER_III"})


def is_lossy(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` holds lossy-coded audio (Vorbis, Opus, MP3)."""
    return probe(path).subtype in LOSSY_SUBTYPES


def read_mono(path: str | os.PathLike[str], sample_rate: int) -> np.ndarray:
    """The sound in ``path`` as mono ``float64`` at ``sample_rate``.

    Parameters
    ----------
    path
        Any file soundfile reads (WAV, FLAC, OGG, ...).
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
    probe(path)  # one-line errors for missing, unreadable and empty files
    try:
        data, rate = sf.read(Path(path), dtype="float64", always_2d=True)
    except (sf.LibsndfileError, RuntimeError) as exc:
        raise AudioError(f"{path}: audio data damaged ({' '.join(str(exc).split())})") from None
    if data.shape[0] == 0:
        raise AudioError(f"{path}: holds no audio (zero-length or truncated)")
    if not np.isfinite(data).all():
        raise AudioError(f"{path}: NaN or infinite samples")
    mono = data.mean(axis=1)
    return resample(mono, int(rate), int(sample_rate))


def resample(x: np.ndarray, rate_in: int, rate_out: int) -> np.ndarray:
    """``x`` at ``rate_in`` converted to ``rate_out`` (identity when the rates agree)."""
    if rate_in == rate_out:
        return np.array(x, dtype=float)
    ratio = Fraction(int(rate_out), int(rate_in))
    return signal.resample_poly(np.asarray(x, dtype=float), ratio.numerator, ratio.denominator)
