"""``detect``: from a recording (file or array) to the table of impact times."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from drumroll.audio.io import DEFAULT_BLOCK_FRAMES, iter_blocks, probe, read_excerpt
from drumroll.errors import AudioError
from drumroll.onsets.candidates import Candidates, CandidateStream
from drumroll.onsets.envelope import next_by_envelope, retime_by_envelope
from drumroll.onsets.follow import Excerpt, FollowParams, flight_predictor, follow
from drumroll.onsets.odf import OdfParams
from drumroll.onsets.sequence import retime
from drumroll.onsets.table import OnsetTable
from drumroll.onsets.tracking import TrackParams, explain, track

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
        mono = _mono(source, name)
        blocks: Iterable[np.ndarray] = (mono[i: i + block_frames]
                                        for i in range(0, mono.size, block_frames))

        def excerpt(start: int, stop: int) -> np.ndarray:
            out = np.zeros(stop - start)
            lo, hi = max(start, 0), min(stop, mono.size)
            if hi > lo:
                out[lo - start: hi - start] = mono[lo:hi]
            return out
    else:
        name = str(Path(source))
        rate = probe(source).sample_rate
        blocks = iter_blocks(source, block_frames)

        def excerpt(start: int, stop: int) -> np.ndarray:
            return read_excerpt(source, start, stop)

    stream = CandidateStream(rate, odf, threshold=threshold)
    for block in blocks:
        stream.feed(block)
    cands = stream.finish()
    return _select(cands, tparams, odf, name, rate, all_candidates, excerpt, stream.total)


def _mono(x: np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 2:
        x = x.mean(axis=1)
    if x.ndim != 1 or x.size == 0:
        raise AudioError(f"{name}: expected a non-empty 1-D or 2-D array of samples")
    if not np.isfinite(x).all():
        raise AudioError(f"{name}: NaN or infinite samples")
    if float(np.abs(x).max()) < 1e-7:
        raise AudioError(f"{name}: the recording is silent")
    return x


def _select(c: Candidates, p: TrackParams, odf: OdfParams, name: str, rate: int,
            all_candidates: bool, excerpt: Callable[[int, int], np.ndarray],
            total: int) -> OnsetTable:
    if len(c) == 0:
        raise AudioError(f"no drumroll found in {name}: no impact-like sound in it")
    tr = track(c, p)
    if tr.index.size <= 1 or tr.score <= 0:
        raise AudioError(f"no drumroll found in {name}: no sequence of bounces "
                         "(a single hit, noise or silence?)")
    kept = c.subset(tr.index)
    # A bouncer starts with its loudest impact: onsets before the first that stands out of
    # the sound it lands in are a tap or noise before the roll.
    timeable = np.flatnonzero(kept.snr_db >= FollowParams().min_snr_db)
    if timeable.size == 0:
        # A pattern in the ring-down or the noise, not a bouncer.
        raise AudioError(f"no drumroll found in {name}: the only sequence of bounces in it "
                         "is quieter than the sound around it")
    kept = kept.subset(np.arange(int(timeable[0]), len(kept)))
    # Three tracked onsets already predict a fourth: the targeted search may supply it.
    cols, ex = _extend(kept, p, odf, rate, excerpt, total)
    if ex is not None:  # each onset timed again with the whole roll's law as its prior
        cols = retime(cols[0], cols[3], ex.x, ex.start, rate, ex.ba, ex.settle) or cols
        # ... and against the sound of the roll's loudest impact, which shows where a faint
        # one's sound starts when its first milliseconds are lost in what it lands in.
        cols = retime_by_envelope(cols, ex.x, ex.start, rate, ex.ba, ex.settle)
    # A flight that grows ends the roll: the onsets after it cannot be numbered.
    tracked = cols[0].size
    cols = until_a_flight_grows(*cols)
    if ex is not None and 3 <= cols[0].size < p.min_onsets:
        cols = _complete(cols, ex, p, rate)
    if cols[0].size < p.min_onsets:
        grew = " before a flight longer than the one before it" \
            if cols[0].size < tracked else ""
        raise AudioError(f"no drumroll found in {name}: only {cols[0].size} impacts in a "
                         f"row{grew}, a drumroll needs at least {p.min_onsets}")
    times = cols[0]
    near = np.searchsorted(times, c.time_s).clip(1, times.size - 1)
    dist = np.minimum(np.abs(c.time_s - times[near - 1]), np.abs(c.time_s - times[near]))
    left_out = np.flatnonzero(dist > _SAME_ONSET_S) if all_candidates else \
        np.zeros(0, dtype=np.int64)
    reasons = explain(c.time_s, times, left_out.tolist())
    return OnsetTable(*cols, rejected_time_s=c.time_s[left_out],
                      rejected_snr_db=c.snr_db[left_out],
                      rejected_reason=[reasons[int(i)] for i in left_out], source=name,
                      sample_rate=rate)


def until_a_flight_grows(times: np.ndarray, *columns: np.ndarray) -> tuple[np.ndarray, ...]:
    """The roll up to (not including) the onset that ends the first flight longer than the
    flight before it.

    Every flight of a bouncer is shorter than the one before it (α < 1, in every model), so a
    flight that grows by more than its timing uncertainty means that a bounce between was
    missed (masked, or too faint) or that an onset is wrong. The onsets after it could then
    not be numbered, and a fit would take bounce k + 1 for bounce k: the roll is reported up
    to the gap (and is no roll at all if too few onsets are left: flights that grow from the
    start are unrelated sounds). ``columns[-1]`` must be the per-onset timing uncertainty
    ``sigma_s``.
    """
    sigma = columns[-1]
    flights = np.diff(times)
    if flights.size < 2:
        return (times, *columns)
    # Each flight difference involves three onset times.
    spread = np.sqrt(sigma[2:] ** 2 + 4.0 * sigma[1:-1] ** 2 + sigma[:-2] ** 2)
    grows = np.flatnonzero(flights[1:] - flights[:-1] > 3.0 * spread)
    if grows.size == 0:
        return (times, *columns)
    return tuple(col[: int(grows[0]) + 2] for col in (times, *columns))


def _complete(cols: tuple[np.ndarray, ...], ex: Excerpt, p: TrackParams, rate: int
              ) -> tuple[np.ndarray, ...]:
    """A roll of three onsets (two flights: one ratio, nothing to test it with) completed
    by bounces found by their whole sound where the flight law puts them
    (:func:`~.envelope.next_by_envelope`), up to the fewest onsets that make a roll."""
    while cols[0].size < p.min_onsets:
        predict = flight_predictor(cols[0], cols[3], FollowParams(ratio_jitter=p.ratio_jitter))
        if predict is None:
            break
        dt, s_log = predict(1)
        found = next_by_envelope(cols, ex.x, ex.start, rate, ex.ba, ex.settle, dt, s_log * dt)
        if found is None:
            break
        cols = found
    return cols


#: Candidates this close to a reported onset are that onset.
_SAME_ONSET_S = 0.001


def _extend(kept: Candidates, p: TrackParams, odf: OdfParams, rate: int,
            excerpt: Callable[[int, int], np.ndarray], total: int
            ) -> tuple[tuple[np.ndarray, ...], Excerpt | None]:
    """The tracked roll, followed past its last onset by the targeted search of
    :mod:`.follow`. Returns time, amplitude, SNR and sigma columns, and the audio around
    the roll (None if the roll was too short to follow)."""
    # Trailing onsets quieter than what they land in were carried by their timing alone;
    # their start cannot be told to the sample, so the roll is reported up to the last one
    # that can (but never below the fewest onsets that make a roll).
    fp = FollowParams(ratio_jitter=p.ratio_jitter)
    timeable = np.flatnonzero(kept.snr_db >= fp.min_snr_db)
    keep = max(int(timeable[-1]) + 1 if timeable.size else 0, min(p.min_onsets, len(kept)))
    kept = kept.subset(np.arange(keep))
    cols = (kept.time_s, kept.amplitude, kept.snr_db, kept.sigma_s)
    if len(kept) < 3:
        return cols, None
    t = kept.time_s
    flights = np.diff(t)
    ratio = float(np.clip(flights[-1] / flights[-2], p.min_ratio, 0.98))
    # The roll cannot last longer than the geometric series of its remaining flights.
    end_s = min(t[-1] + flights[-1] * ratio / (1.0 - ratio) + 0.05, total / rate)
    start = max(int((t[0] - _CONTEXT_S) * rate), 0)
    stop = min(int((end_s + _CONTEXT_S) * rate), total)
    ex = Excerpt(excerpt(start, stop), start, rate, odf)
    found = follow(list(t), list(kept.sigma_s), ex, fp, p.min_interval_s, end_s)
    return tuple(np.concatenate((b, np.asarray(f, dtype=float)))
                 for b, f in zip(cols, (found.time_s, found.amplitude, found.snr_db,
                                        found.sigma_s), strict=True)), ex


#: Audio read either side of the roll for the detection function's statistics.
_CONTEXT_S = 1.0
