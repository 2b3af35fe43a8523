"""``detect``: from a recording (file or array) to the table of every roll's impact times.

The work is a list of stages over one record type, in the way madmom composes processors.
The recording is streamed once into candidate impacts (:mod:`.candidates`); the tracker
chooses the rolls among them and numbers their bounces (:mod:`.tracking`); then every roll
goes through :data:`STAGES` in order, each a function ``(roll, excerpt, context) -> roll``
on a :class:`~.roll.Roll` and the audio around it (:class:`~.excerpt.Excerpt`). A new stage
is one function and one line in that list.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from drumroll.audio.io import DEFAULT_BLOCK_FRAMES, AudioInfo, iter_blocks, probe, read_excerpt
from drumroll.audio.timing import pre_echo_s, timing_floor
from drumroll.errors import AudioError, DrumrollWarning
from drumroll.onsets.candidates import Candidates, CandidateStream
from drumroll.onsets.channels import earliest_channel
from drumroll.onsets.envelope import next_by_envelope, retime_by_envelope
from drumroll.onsets.excerpt import Excerpt
from drumroll.onsets.follow import OFF_LAW, FollowParams, follow
from drumroll.onsets.odf import OdfParams, highest_highpass
from drumroll.onsets.prediction import flight_predictor
from drumroll.onsets.roll import Roll
from drumroll.onsets.sequence import retime_by_law
from drumroll.onsets.start import first_in_ring, on_course, time_at_start, with_floor
from drumroll.onsets.table import OnsetTable
from drumroll.onsets.tracking import Track, TrackParams, explain, track

_ODF_KEYS = {"hop_s", "highpass_hz", "post_s", "pre_s"}
_TRACK_KEYS = set(TrackParams.__dataclass_fields__)


@dataclass(frozen=True)
class Context:
    """What the stages share: the settings and where the recording ends."""

    track: TrackParams
    follow: FollowParams
    end_s: float
    #: The stretch (samples) a lossy file's codec may spread noise ahead of an impact by
    #: (:func:`~drumroll.audio.timing.pre_echo_s`); 0 for lossless audio.
    codec_block: int = 0
    #: A lossy file's timing floor (sd, seconds; :func:`~drumroll.audio.timing.timing_floor`):
    #: part of every onset's timing wherever the stages test an onset against the flight
    #: law (:func:`~.start.with_floor`); 0 for lossless audio.
    floor_s: float = 0.0


Stage = Callable[[Roll, Excerpt, Context], Roll]


def from_first_timeable(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """The roll from its first onset that stands out of what it lands in: a bouncer's first
    impact is the one that lands in silence, so an onset before it that is quieter than its
    surroundings is a tap or noise the timing happened to fit."""
    timeable = np.flatnonzero(roll.snr_db >= ctx.follow.min_snr_db)
    if timeable.size == 0:
        return Roll.empty()
    return roll.subset(slice(int(timeable[0]), None)).renumbered()


def up_to_the_last_timeable(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """Trailing onsets quieter than what they land in were carried by their timing alone;
    their start cannot be told to the sample, so the roll is reported up to the last one that
    can (the targeted search then looks for each of them again)."""
    timeable = np.flatnonzero(roll.snr_db >= ctx.follow.min_snr_db)
    keep = max(int(timeable[-1]) + 1 if timeable.size else 0,
               min(ctx.track.min_onsets, len(roll)))
    return roll.subset(slice(0, keep))


def sound_starts(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """Every onset later than the bounces before it put it moved to an earlier start of its
    sound (:func:`~.start.time_at_start`)."""
    return time_at_start(roll, ex)


def off_course(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """Onsets far from where the bounces before them put them dropped
    (:func:`~.start.on_course`)."""
    return on_course(roll, OFF_LAW, ex.floor_s)


def in_ring(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """The first impact timed as if it had landed in the ring the next ones land in
    (:func:`~.start.first_in_ring`)."""
    return first_in_ring(roll, ex)


def onwards(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """The roll followed past its last onset, window by window (:func:`~.follow.follow`)."""
    return follow(roll, ex, ctx.follow, min(_predicted_end(roll), ctx.end_s))


def law(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """Every onset timed again with the whole roll's law as its prior
    (:func:`~.sequence.retime_by_law`)."""
    return retime_by_law(roll, ex, min_snr_db=ctx.follow.min_snr_db)


def envelope(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """Every faint onset timed against the sound of the roll's loudest impact
    (:func:`~.envelope.retime_by_envelope`)."""
    return retime_by_envelope(roll, ex)


def completed(roll: Roll, ex: Excerpt, ctx: Context) -> Roll:
    """A roll of three onsets (two flights: one ratio, nothing to test it with) completed
    by bounces found by their whole sound where the flight law puts them
    (:func:`~.envelope.next_by_envelope`), up to the fewest onsets that make a roll."""
    while 3 <= len(roll) < ctx.track.min_onsets:
        predict = flight_predictor(roll.time_s, roll.bounce,
                                   with_floor(roll.sigma_s, ex.floor_s), ctx.follow.history,
                                   ctx.follow.ratio_jitter)
        if predict is None:
            break
        dt, s_log = predict(1)
        found = next_by_envelope(roll, ex, dt, s_log * dt)
        if found is None:
            break
        roll = found
    return roll


#: What is done to every roll the tracker finds, in order.
STAGES: tuple[Stage, ...] = (
    from_first_timeable,
    up_to_the_last_timeable,
    sound_starts,
    onwards,
    law,
    envelope,
    off_course,
    in_ring,
    completed,
)


def detect(source: str | os.PathLike[str] | np.ndarray, sr: int | None = None, *,
           threshold: float = 5.0, all_candidates: bool = False,
           block_frames: int = DEFAULT_BLOCK_FRAMES, stream: int | None = None,
           **options: float) -> OnsetTable:
    """Find the impacts of every drumroll (or other free bouncer) in a recording.

    Parameters
    ----------
    source
        A recording (read in blocks: any length): what soundfile reads, and what phones and
        cameras write, which FFmpeg decodes (:mod:`drumroll.audio.io`); or an array of samples
        (``(n,)`` or ``(n, channels)``) together with ``sr``. Candidates are found on the
        mean of the channels, onsets timed on the one that hears them first
        (:mod:`.channels`). Where the file's codec or rate limits how well an onset can be
        timed, each ``sigma_s`` has that limit added (in quadrature) and a
        :class:`~drumroll.errors.DrumrollWarning` says so (:mod:`drumroll.audio.timing`).
    sr
        Sample rate of an array ``source``; ignored for files.
    threshold
        Significance, in robust standard deviations of the detection function, for a sound
        to become a candidate impact.
    all_candidates
        Also return the candidates that are no onset of a roll, each with its reason.
    block_frames
        Samples read per block from a file.
    stream
        Which audio stream of a file (0-based among its audio streams; default the first, or
        that of a :class:`~drumroll.audio.AudioSource`).
    **options
        Detection-function settings (:class:`~drumroll.onsets.odf.OdfParams`: ``hop_s``,
        ``highpass_hz``, ``post_s``, ``pre_s``) and tracker settings
        (:class:`~drumroll.onsets.tracking.TrackParams`, e.g. ``max_interval_s``,
        ``min_ratio``, ``ratio_jitter``, ``min_onsets``).

    Returns
    -------
    OnsetTable
        Every roll's bounces in time order, with bounce and roll numbers, amplitude, local
        SNR, timing uncertainty and interval.

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

    info: AudioInfo | None = None
    if isinstance(source, np.ndarray):
        name = "<array>"
        if sr is None or sr <= 0:
            raise AudioError(f"{name}: a sample rate (sr) is needed with an array")
        rate = int(sr)
        samples = _samples(source, name)
        n_channels = samples.shape[1]
        mono = samples.mean(axis=1)
        blocks: Iterable[np.ndarray] = (mono[i: i + block_frames]
                                        for i in range(0, mono.size, block_frames))

        def excerpt(start: int, stop: int, channel: int | None = None) -> np.ndarray:
            out = np.zeros(stop - start)
            lo, hi = max(start, 0), min(stop, mono.size)
            if hi > lo:
                out[lo - start: hi - start] = (mono[lo:hi] if channel is None
                                               else samples[lo:hi, channel])
            return out
    else:
        name = str(Path(source))
        which = stream  # (``stream`` names the candidate stream below)
        info = probe(source, stream=which)
        rate, n_channels = info.sample_rate, info.channels
        blocks = iter_blocks(source, block_frames, stream=which)

        def excerpt(start: int, stop: int, channel: int | None = None) -> np.ndarray:
            return read_excerpt(source, start, stop, channel, stream=which)

    highest = highest_highpass(rate)
    if odf.highpass_hz > highest:
        # The analysis bands tile highpass_hz up to 0.45 of the rate: above this there is
        # no band left to analyse, and the filter would be capped here without a word.
        raise AudioError(f"{name}: a high-pass of {odf.highpass_hz:g} Hz leaves nothing to "
                         f"analyse at {rate} Hz: give at most {highest:g} Hz")
    # A lossy codec's noise may come before an impact by up to one transform window: the
    # onsets are timed where the sound steps out of it (:mod:`.refine`).
    codec_block = 0 if info is None else round(pre_echo_s(info) * rate)
    stream = CandidateStream(rate, odf, threshold=threshold, codec_block=codec_block)
    for block in blocks:
        stream.feed(block)
    cands = stream.finish()
    if info is not None:  # a file cut short holds less than its header said
        info = info.holding(stream.total)
    if len(cands) == 0 and n_channels > 1 and _channels_cancel(excerpt, n_channels,
                                                               stream.total, rate):
        raise AudioError(f"no drumroll found in {name}: its channels cancel when mixed to "
                         "mono (one is the other with its polarity inverted, as a microphone "
                         "wired in reverse gives): invert one channel, or keep one, in an "
                         "audio editor")
    # The candidates are found on the mean of the channels; the onsets are timed on the
    # channel that hears them first.
    channel = earliest_channel(cands, n_channels, rate, odf, excerpt)
    ctx = Context(tparams, FollowParams(ratio_jitter=tparams.ratio_jitter,
                                        min_interval_s=tparams.min_interval_s),
                  stream.total / rate, codec_block, _codec_floor_s(info))
    rolls = _rolls(cands, ctx, odf, name, rate,
                   lambda start, stop: excerpt(start, stop, channel))
    table = _table(rolls, cands, name, rate, all_candidates, channel)
    return table if info is None else _with_codec_floor(table, info)


#: A mono mix this far under its channels (rms, here -20 dB) is cancellation, not a mix:
#: channels of one sound add up (0 dB, or -3 dB when they are unrelated).
_CANCELLED = 0.1


def _channels_cancel(excerpt: Callable[..., np.ndarray], n_channels: int, frames: int,
                     rate: int, seconds: float = 10.0) -> bool:
    """Whether the mean of the channels is far quieter than the channels themselves over the
    recording's first ``seconds``: a channel in reverse polarity, which mixing silences."""
    n = min(frames, round(seconds * rate))
    if n <= 0:
        return False
    mixed = float(np.sqrt(np.mean(excerpt(0, n) ** 2)))
    each = float(np.sqrt(np.mean([np.mean(excerpt(0, n, ch) ** 2)
                                  for ch in range(n_channels)])))
    return each > 0.0 and mixed < _CANCELLED * each


def _with_codec_floor(table: OnsetTable, info: AudioInfo) -> OnsetTable:
    """The table with the timing floor of the file's codec and rate added to every
    ``sigma_s`` (in quadrature), and a one-line warning saying so; unchanged for a file
    whose codec and rate limit nothing (:func:`~drumroll.audio.timing.timing_floor`)."""
    floor = timing_floor(info)
    if floor is None:
        return table
    warnings.warn(floor.message, DrumrollWarning, stacklevel=3)
    return replace(table, sigma_s=np.hypot(table.sigma_s, floor.sd_s))


def _codec_floor_s(info: AudioInfo | None) -> float:
    """The timing floor (sd, seconds) of a lossy file's codec, which the stages allow for
    while they test onsets against the flight law; 0 for lossless audio, whose onsets take
    the stages exactly as before (a low sample rate's floor is only added to the table)."""
    if info is None or info.lossless:
        return 0.0
    floor = timing_floor(info)
    return 0.0 if floor is None else floor.sd_s


def _samples(x: np.ndarray, name: str) -> np.ndarray:
    """An array source as ``(frames, channels)`` float64, checked."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.size == 0:
        raise AudioError(f"{name}: expected a non-empty 1-D or 2-D array of samples")
    if not np.isfinite(x).all():
        raise AudioError(f"{name}: NaN or infinite samples")
    if float(np.abs(x).max()) < 1e-7:
        raise AudioError(f"{name}: the recording is silent")
    return x


def _rolls(c: Candidates, ctx: Context, odf: OdfParams, name: str, rate: int,
           excerpt: Callable[[int, int], np.ndarray]) -> list[Roll]:
    """Every roll the tracker finds, through :data:`STAGES`, in time order; those left with
    fewer than ``min_onsets`` onsets are dropped. Raises AudioError, saying why, if none is
    left."""
    if len(c) == 0:
        raise AudioError(f"no drumroll found in {name}: no impact-like sound in it")
    tracks = track(c, ctx.track)
    if not tracks:
        raise AudioError(f"no drumroll found in {name}: no sequence of bounces "
                         "(a single hit, noise or silence?)")
    rolls, longest = [], 0
    for tr in sorted(tracks, key=lambda tr: c.time_s[tr.index[0]]):
        roll = _initial(c, tr)
        ex = _excerpt_around(roll, ctx, odf, rate, excerpt)
        for stage in STAGES:
            if len(roll) == 0:
                break
            roll = stage(roll, ex, ctx)
        longest = max(longest, len(roll))
        if len(roll) >= ctx.track.min_onsets:
            rolls.append(roll)
    if rolls:
        return _without_overlaps(rolls)
    if longest == 0:  # every sequence was quieter than its surroundings
        raise AudioError(f"no drumroll found in {name}: the only sequence of bounces in it "
                         "is quieter than the sound around it")
    raise AudioError(f"no drumroll found in {name}: only {longest} impacts in a row, a "
                     f"drumroll needs at least {ctx.track.min_onsets}")


def _initial(c: Candidates, tr: Track) -> Roll:
    kept = c.subset(tr.index)
    return Roll(kept.time_s, tr.bounce, kept.amplitude, kept.snr_db, kept.sigma_s,
                kept.level)


def _without_overlaps(rolls: list[Roll]) -> list[Roll]:
    """Rolls in time order; where following one ran into the next, the longer keeps the
    shared stretch (a bouncer makes one roll at a time)."""
    out: list[Roll] = []
    for roll in rolls:
        if out and roll.time_s[0] <= out[-1].time_s[-1]:
            if len(roll) > len(out[-1]):
                out[-1] = roll
            continue
        out.append(roll)
    return out


def _predicted_end(roll: Roll) -> float:
    """Where the roll's flights, continued at their last ratio, would have died out."""
    flights, _ = roll.flights()
    t = roll.time_s
    if flights.size < 2:
        return float(t[-1] + (flights[-1] if flights.size else 0.5))
    ratio = float(np.clip(flights[-1] / flights[-2], 0.25, 0.98))
    return float(t[-1] + flights[-1] * ratio / (1.0 - ratio) + 0.05)


def _excerpt_around(roll: Roll, ctx: Context, odf: OdfParams, rate: int,
                    excerpt: Callable[[int, int], np.ndarray]) -> Excerpt:
    """The audio from before the roll (for the detection function's statistics) to after
    its predicted end."""
    t = roll.time_s
    start = max(int((t[0] - _CONTEXT_S) * rate), 0)
    end_s = min(_predicted_end(roll), ctx.end_s)
    stop = min(int((end_s + _CONTEXT_S) * rate), int(ctx.end_s * rate))
    return Excerpt(excerpt(start, stop), start, rate, odf, ctx.codec_block, ctx.floor_s)


def _table(rolls: list[Roll], c: Candidates, name: str, rate: int, all_candidates: bool,
           channel: int | None) -> OnsetTable:
    """The onset table of the rolls; with ``all_candidates``, every candidate that is no
    onset of a roll, with the reason."""
    times = np.concatenate([r.time_s for r in rolls])
    roll_of = np.concatenate([np.full(len(r), i) for i, r in enumerate(rolls)])
    columns = {f: np.concatenate([getattr(r, f) for r in rolls])
               for f in ("bounce", "amplitude", "snr_db", "sigma_s")}
    rejected = np.zeros(0, dtype=np.int64)
    reasons: list[str] = []
    if all_candidates:
        near = np.searchsorted(times, c.time_s).clip(1, times.size - 1)
        dist = np.minimum(np.abs(c.time_s - times[near - 1]), np.abs(c.time_s - times[near]))
        rejected = np.flatnonzero(dist > _SAME_ONSET_S)
        for i in rejected.tolist():
            # Explained against the roll nearest to it.
            centre = np.array([0.5 * (r.time_s[0] + r.time_s[-1]) for r in rolls])
            roll = rolls[int(np.argmin(np.abs(centre - c.time_s[i])))]
            reasons.append(explain(c.time_s, roll.time_s, [i])[i])
    return OnsetTable(times, columns["amplitude"], columns["snr_db"], columns["sigma_s"],
                      rejected_time_s=c.time_s[rejected], rejected_snr_db=c.snr_db[rejected],
                      rejected_reason=reasons, source=name, sample_rate=rate,
                      channel=channel, bounce=columns["bounce"], roll=roll_of)


#: Candidates this close to a reported onset are that onset.
_SAME_ONSET_S = 0.001

#: Audio read either side of the roll for the detection function's statistics.
_CONTEXT_S = 1.0
