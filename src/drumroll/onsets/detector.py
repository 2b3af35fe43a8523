"""``detect``: from a recording (file or array) to the table of impact times."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from drumroll.audio.io import DEFAULT_BLOCK_FRAMES, iter_blocks, probe
from drumroll.errors import AudioError
from drumroll.onsets.candidates import Candidates, CandidateStream
from drumroll.onsets.odf import OdfParams
from drumroll.onsets.table import OnsetTable
from drumroll.onsets.tracking import TrackParams, track

_ODF_KEYS = {"hop_s", "highpass_hz", "post_s", "pre_s"}
_TRACK_KEYS = set(TrackParams.__dataclass_fields__)


def detect(source: str | os.PathLike[str] | np.ndarray, sr: int | None = None, *,
           threshold: float = 5.0, all_candidates: bool = False,
           block_frames: int = DEFAULT_BLOCK_FRAMES, **options: float) -> OnsetTable:
    """Find the impacts of a drumroll (or any free bouncer) in a recording.

    Parameters
    ----------
    source
        A file soundfile reads (read in blocks: any length), or an array of samples
        (``(n,)`` or ``(n, channels)``; channels are averaged) together with ``sr``.
    sr
        Sample rate of an array ``source``; ignored for files.
    threshold
        Significance, in robust standard deviations of the detection function, for a sound
        to become a candidate impact.
    all_candidates
        Also return the candidates the tracker rejected, each with its reason.
    block_frames
        Samples read per block from a file.
    **options
        Detection-function settings (:class:`~drumroll.onsets.odf.OdfParams`: ``hop_s``,
        ``highpass_hz``, ``post_s``, ``pre_s``) and tracker settings
        (:class:`~drumroll.onsets.tracking.TrackParams`, e.g. ``max_interval_s``,
        ``min_ratio``, ``ratio_jitter``, ``min_onsets``).

    Returns
    -------
    OnsetTable
        The bounces in time order with amplitude, local SNR, timing uncertainty and interval.

    Raises
    ------
    AudioError
        Unreadable input, or no drumroll in it (silence, noise, a single hit).
    """
    unknown = set(options) - _ODF_KEYS - _TRACK_KEYS
    if unknown:
        raise TypeError(f"detect() got unknown option(s): {', '.join(sorted(unknown))}")
    odf = OdfParams(**{k: v for k, v in options.items() if k in _ODF_KEYS})
    tparams = TrackParams(**{k: v for k, v in options.items() if k in _TRACK_KEYS})

    if isinstance(source, np.ndarray):
        name = "<array>"
        if sr is None or sr <= 0:
            raise AudioError(f"{name}: a sample rate (sr) is needed with an array")
        rate = int(sr)
        blocks = _array_blocks(source, block_frames, name)
    else:
        name = str(Path(source))
        rate = probe(source).sample_rate
        blocks = iter_blocks(source, block_frames)

    stream = CandidateStream(rate, odf, threshold=threshold)
    for block in blocks:
        stream.feed(block)
    cands = stream.finish()
    return _select(cands, tparams, name, rate, all_candidates)


def _array_blocks(x: np.ndarray, block_frames: int, name: str) -> Iterable[np.ndarray]:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 2:
        x = x.mean(axis=1)
    if x.ndim != 1 or x.size == 0:
        raise AudioError(f"{name}: expected a non-empty 1-D or 2-D array of samples")
    if not np.isfinite(x).all():
        raise AudioError(f"{name}: NaN or infinite samples")
    if float(np.abs(x).max()) < 1e-7:
        raise AudioError(f"{name}: the recording is silent")
    return (x[i: i + block_frames] for i in range(0, x.size, block_frames))


def _select(c: Candidates, p: TrackParams, name: str, rate: int,
            all_candidates: bool) -> OnsetTable:
    if len(c) == 0:
        raise AudioError(f"no drumroll found in {name}: no impact-like sound in it")
    tr = track(c, p)
    if tr.index.size < p.min_onsets or tr.score <= 0:
        if tr.index.size <= 1 or tr.score <= 0:
            raise AudioError(f"no drumroll found in {name}: no sequence of bounces "
                             "(a single hit, noise or silence?)")
        raise AudioError(f"no drumroll found in {name}: only {tr.index.size} impacts in a "
                         f"row, a drumroll needs at least {p.min_onsets}")
    kept = c.subset(tr.index)
    rejected = np.asarray(sorted(tr.reasons), dtype=np.int64) if all_candidates else \
        np.zeros(0, dtype=np.int64)
    return OnsetTable(kept.time_s, kept.amplitude, kept.snr_db, kept.sigma_s,
                      rejected_time_s=c.time_s[rejected], rejected_snr_db=c.snr_db[rejected],
                      rejected_reason=[tr.reasons[int(i)] for i in rejected], source=name,
                      sample_rate=rate)
