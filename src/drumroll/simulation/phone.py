"""What a voice-memo app does to a recording before it is coded: automatic gain control.

A phone's recorder keeps speech at one loudness: a fast compressor pulls a loud sound down
within a millisecond and lets go over about 100 ms, and a make-up gain lifts the whole
recording to a target level. On a drumroll this flattens the loud first impacts against the
faint last ones, and "pumps": after each loud impact the gain comes back up through the
ring and the noise, so the faint impacts that follow are lifted by different amounts.

:func:`phone_agc` is that processing (feed-forward: the level is measured on the input, as
a recorder's is), used by the benchmark's phone conditions and by the tests, which check
that every audible impact is still found through it.
"""

from __future__ import annotations

import numpy as np


def phone_agc(x: np.ndarray, sample_rate: int, *, threshold_db: float = -40.0,
              ratio: float = 8.0, attack_s: float = 0.001, release_s: float = 0.1,
              target_dbfs: float = -3.0) -> np.ndarray:
    """A recording through a phone's automatic gain control (a feed-forward compressor with
    make-up gain).

    Parameters
    ----------
    x
        ``(n,)`` or ``(n, channels)`` samples, full scale 1.
    sample_rate
        Their rate.
    threshold_db
        Level (dBFS, of the peak envelope) above which the gain comes down.
    ratio
        Compression ratio above the threshold (input dB per output dB; at least 4 for an
        AGC that flattens).
    attack_s, release_s
        Time constants of the peak envelope rising and falling (fast attack; the release
        sets the pumping).
    target_dbfs
        Peak level of the result: the make-up gain, applied last, puts the loudest sample
        there (a constant gain: it moves no onset).

    Returns
    -------
    numpy.ndarray
        The processed samples, the shape of ``x``.
    """
    if ratio < 1.0:
        raise ValueError(f"ratio must be at least 1, got {ratio}")
    x = np.asarray(x, dtype=np.float64)
    level = np.abs(x) if x.ndim == 1 else np.abs(x).max(axis=1)
    env = _peak_envelope(level, sample_rate, attack_s, release_s)
    env_db = 20.0 * np.log10(np.maximum(env, 1e-10))
    over = np.maximum(env_db - threshold_db, 0.0)
    gain = 10.0 ** (-over * (1.0 - 1.0 / ratio) / 20.0)
    y = x * (gain if x.ndim == 1 else gain[:, None])
    peak = float(np.abs(y).max())
    return y * (10.0 ** (target_dbfs / 20.0) / peak) if peak > 0 else y


def _peak_envelope(level: np.ndarray, sample_rate: int, attack_s: float,
                   release_s: float) -> np.ndarray:
    """One-pole peak follower: rises towards a louder input with ``attack_s``, falls with
    ``release_s`` (the switch makes it nonlinear: a loop, about 0.1 s per minute of
    44.1 kHz audio... per ten seconds; fine for the benchmark's recordings)."""
    a_att = float(np.exp(-1.0 / (attack_s * sample_rate)))
    a_rel = float(np.exp(-1.0 / (release_s * sample_rate)))
    out = np.empty_like(level)
    e = 0.0
    for i, v in enumerate(level.tolist()):
        e = (a_att * e + (1.0 - a_att) * v) if v > e else (a_rel * e + (1.0 - a_rel) * v)
        out[i] = e
    return out
