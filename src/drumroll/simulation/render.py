"""Mix a drumroll recording with known truth: impacts, room, noise, hum, stray sounds.

The mixture of one channel is ``room(sum of all impacts and spurious events) + noise + hum``:
every impact keeps ringing under the later ones, the room's echo and reverberation apply to
all of them, and the noise and hum are independent of the sound. The file is then scaled so
its peak sits at ``peak_dbfs`` or, with ``clip_db``, driven that far above ``peak_dbfs`` and
clipped there (see :func:`level_and_clip`). The room is a synthetic :class:`Room` or a
:class:`~drumroll.simulation.measured_room.MeasuredRoom`.

Truth conventions
-----------------
* ``impact_times_s`` are the instants of first contact, in seconds from the file's first
  sample; an impact's sound is exactly zero at every sample before that instant. They refer
  to channel 0; further channels hear everything slightly later (up to 0.5 ms) and at a
  slightly different gain, with their own noise and reverberation.
* ``local_snr_db[k]`` is the benchmark's audibility measure of impact k: the energy of its
  own direct sound in the 3 ms after its onset, after a causal 4th-order Butterworth
  high-pass at 1.5 kHz, over the energy of everything else in channel 0 in the same window
  and band (earlier impacts' ringing, the echo and reverberation of all sounds, the noise,
  the hum, spurious events). It is computed exactly, by rendering the impact alone over that
  window, before scaling, clipping and quantisation; it is capped at +-200 dB.

:func:`~drumroll.simulation.render_hits.render_hits` makes the same kind of recording from
recorded hits and keeps these conventions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import signal

from drumroll.simulation.disturbances import (
    REFERENCE_WINDOW_S,
    Disturbances,
    background_noise,
    mains_hum,
    plan_spurious,
)
from drumroll.simulation.measured_room import MeasuredRoom
from drumroll.simulation.room import (
    Room,
    RoomResponse,
    apply_room,
    draw_echo_delay,
    room_response,
)
from drumroll.simulation.sounds import DrumSound, ImpactSynth

#: Window and high-pass corner of the local SNR (see the module docstring).
LOCAL_SNR_WINDOW_S = 0.003
LOCAL_SNR_HIGHPASS_HZ = 1500.0
_SNR_CAP_DB = 200.0


@dataclass(frozen=True)
class Rendering:
    """A rendered recording and its truth.

    Attributes
    ----------
    samples
        float64 samples, ``(frames,)`` for one channel or ``(frames, channels)``, peak at
        ``peak_dbfs``.
    sample_rate
        Samples per second.
    impact_times_s
        Impact times as placed in the file (the requested times plus ``lead_in_s``).
    impact_speeds_m_s
        Impact speeds, m/s.
    local_snr_db
        Per-impact local SNR (see the module docstring).
    spurious_times_s, spurious_kinds
        Times (in the file) and kinds ("tap", "knock") of sounds that are not impacts.
    scale
        Factor applied to the mixture for the peak normalisation.
    lead_in_s
        Time of the requested time origin in the file (lengthened to fit a spurious tap).
    reference_power
        ``P_ref`` of :mod:`drumroll.simulation.disturbances`, before scaling.
    echo_delay_s
        Each channel's echo delay, or ``None`` without an echo.
    channel_delays_s, channel_gains
        Each channel's delay and gain relative to channel 0.
    details
        What else a renderer reports (e.g. the recorded hits' files, layers and levels, the
        clipping), added to :meth:`truth` as is.
    """

    samples: np.ndarray = field(repr=False)
    sample_rate: int
    impact_times_s: np.ndarray
    impact_speeds_m_s: np.ndarray
    local_snr_db: np.ndarray
    spurious_times_s: np.ndarray
    spurious_kinds: tuple[str, ...]
    scale: float
    lead_in_s: float
    reference_power: float
    echo_delay_s: tuple[float, ...] | None
    channel_delays_s: tuple[float, ...]
    channel_gains: tuple[float, ...]
    details: dict[str, Any] = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        """Length of the recording in seconds."""
        return len(self.samples) / self.sample_rate

    def truth(self) -> dict:
        """The truth as JSON-ready plain Python values."""
        return {
            "sample_rate": int(self.sample_rate),
            "channels": 1 if self.samples.ndim == 1 else int(self.samples.shape[1]),
            "frames": len(self.samples),
            "truth_convention": "impact_times_s: first instant of contact, seconds from the "
                                "file's first sample, channel 0; nothing of an impact's sound "
                                "precedes it",
            "impact_times_s": [float(t) for t in self.impact_times_s],
            "impact_speeds_m_s": [float(v) for v in self.impact_speeds_m_s],
            "local_snr_db": [float(s) for s in self.local_snr_db],
            "local_snr_definition": "own direct sound vs everything else, 3 ms after onset, "
                                    "after a 1.5 kHz 4th-order Butterworth high-pass",
            "spurious_times_s": [float(t) for t in self.spurious_times_s],
            "spurious_kinds": list(self.spurious_kinds),
            "scale": float(self.scale),
            "lead_in_s": float(self.lead_in_s),
            "reference_power": float(self.reference_power),
            "echo_delay_s": None if self.echo_delay_s is None else list(self.echo_delay_s),
            "channel_delays_s": list(self.channel_delays_s),
            "channel_gains": list(self.channel_gains),
            **self.details,
        }


_DRUM, _ROOM, _DISTURBANCES = DrumSound(), Room(), Disturbances()


def render(impact_times_s, impact_speeds_m_s, *, sample_rate: int = 44100,
           drum: DrumSound = _DRUM, room: Room | MeasuredRoom = _ROOM,
           disturbances: Disturbances = _DISTURBANCES, channels: int = 1,
           rng: np.random.Generator, peak_dbfs: float = -1.0,
           clip_db: float | None = None) -> Rendering:
    """Render a drumroll recording with known impact times.

    Parameters
    ----------
    impact_times_s
        Impact times (seconds, non-decreasing), relative to any origin; the origin is placed
        ``lead_in_s`` after the start of the file.
    impact_speeds_m_s
        Tip speed at each impact (m/s, positive): sets loudness, brightness, contact time.
    sample_rate
        Samples per second.
    drum, room, disturbances
        The instrument, the room (synthetic, or measured at ``sample_rate``), and what else
        the microphone hears.
    channels
        Number of channels (1 or more); channels differ slightly in delay and gain and have
        independent noise and reverberation.
    rng
        All randomness comes from here: the same generator state gives the same recording.
    peak_dbfs
        Peak level of the result (dB re full scale, at most 0).
    clip_db
        ``None`` or 0: no clipping; else drive the peak this many dB above ``peak_dbfs`` and
        clip at ``peak_dbfs`` (see :func:`level_and_clip`).

    Returns
    -------
    Rendering
        Samples and truth; see the module docstring for the conventions.
    """
    times = np.asarray(impact_times_s, dtype=float)
    speeds = np.asarray(impact_speeds_m_s, dtype=float)
    check_inputs(times, speeds, sample_rate, channels, peak_dbfs, clip_db)
    if isinstance(room, MeasuredRoom) and room.sample_rate != int(sample_rate):
        raise ValueError(f"the measured room is at {room.sample_rate} Hz, the recording at "
                         f"{sample_rate} Hz")
    fs = int(sample_rate)
    r_voice, r_stream, r_spur, r_room, r_noise, r_hum, r_chan = rng.spawn(7)

    synth = ImpactSynth(drum, fs)
    voices = synth.voices(speeds, r_voice)
    events = plan_spurious(drum, float(speeds[0]), float(times[-1] - times[0]), r_spur) \
        if disturbances.spurious else []
    lead = disturbances.lead_in_s
    end = times[-1] + disturbances.tail_s
    for ev in events:  # the tap must fit after the file's start, the knock before its end
        lead = max(lead, 0.2 - (times[0] + ev.time_s))
        end = max(end, times[0] + ev.time_s + 0.5)
    onsets = times + lead
    spur_onsets = np.array([lead + times[0] + ev.time_s for ev in events])
    n_frames = int(np.ceil((lead + end) * fs)) + 1
    click_noise, snare_noise = synth.noise_streams(n_frames, r_stream)
    spur_synths = [ImpactSynth(ev.drum, fs) for ev in events]
    spur = [(s, s.voices(np.array([ev.speed_m_s]), r_spur)[0])
            for s, ev in zip(spur_synths, events, strict=True)]

    delays = np.concatenate([[0.0], r_chan.uniform(0.05e-3, 0.5e-3, channels - 1)])
    gains = np.concatenate([[1.0], 10 ** (r_chan.uniform(-1.5, 1.5, channels - 1) / 20)])
    echo0 = None if isinstance(room, MeasuredRoom) else draw_echo_delay(room, r_room)
    echoes = None if echo0 is None else [echo0, *np.maximum(
        echo0 + r_room.uniform(-0.3e-3, 0.3e-3, channels - 1), 0.5e-3)]

    p_ref = _reference_power(synth, voices, onsets, fs, click_noise, snare_noise)
    hum = (np.sqrt(p_ref * 10 ** (disturbances.hum_db / 10))
           * mains_hum(n_frames, fs, disturbances, r_hum)) if disturbances.hum_hz else 0.0
    mixes = []
    wet_gain = 1.0
    for c in range(channels):
        dry = np.zeros(n_frames)
        for v, t in zip(voices, onsets, strict=True):
            synth.add_hit(dry, 0, v, t + delays[c], click_noise, snare_noise)
        for (s, v), t in zip(spur, spur_onsets, strict=True):
            s.add_hit(dry, 0, v, t + delays[c], click_noise, snare_noise)
        dry *= gains[c]
        if isinstance(room, MeasuredRoom):
            if c == 0:  # one gain for every channel: the room is one filter
                wet_gain = room.gain(dry, signal.oaconvolve(dry, room.wet)[:n_frames])
            response = RoomResponse(wet_gain * room.wet, None)
        else:
            response = room_response(room, fs, r_room, None if echoes is None else echoes[c])
        mix = apply_room(dry, response) + hum
        if disturbances.snr_db is not None:
            mix += np.sqrt(p_ref * 10 ** (-disturbances.snr_db / 10)) \
                * background_noise(n_frames, fs, disturbances, r_noise)
        mixes.append(mix)

    local = _local_snr(mixes[0], synth, voices, onsets, fs, click_noise, snare_noise)
    samples = mixes[0] if channels == 1 else np.stack(mixes, axis=1)
    samples, scale, clipped = level_and_clip(samples, peak_dbfs, clip_db)
    return Rendering(
        samples=samples, sample_rate=fs, impact_times_s=onsets, impact_speeds_m_s=speeds.copy(),
        local_snr_db=local, spurious_times_s=spur_onsets,
        spurious_kinds=tuple(ev.kind for ev in events), scale=scale, lead_in_s=float(lead),
        reference_power=p_ref,
        echo_delay_s=None if echoes is None else tuple(float(e) for e in echoes),
        channel_delays_s=tuple(float(d) for d in delays),
        channel_gains=tuple(float(g) for g in gains),
        details={**({"measured_room": room.truth(wet_gain)}
                    if isinstance(room, MeasuredRoom) else {}),
                 **clip_details(clip_db, clipped)},
    )


def level_and_clip(samples: np.ndarray, peak_dbfs: float, clip_db: float | None
                   ) -> tuple[np.ndarray, float, int]:
    """Scale a mixture to its final level, clipping it if asked (in place).

    Without clipping (``clip_db`` None or 0) the peak lands at ``peak_dbfs``. With
    ``clip_db > 0`` the mixture is scaled so that its peak would lie ``clip_db`` above
    ``peak_dbfs`` and every sample beyond ``+-10**(peak_dbfs / 20)`` is clipped there, as an
    overdriven converter (``peak_dbfs = 0``) or a clipping preamplifier does.

    Returns
    -------
    samples, scale, clipped
        The result, the factor applied before clipping, and the number of clipped samples.
    """
    peak = float(np.max(np.abs(samples)))
    drive = peak_dbfs + (clip_db or 0.0)
    scale = 10 ** (drive / 20) / peak if peak > 0 else 1.0
    samples *= scale
    clipped = 0
    if clip_db:
        ceiling = 10 ** (peak_dbfs / 20)
        over = np.abs(samples) > ceiling
        clipped = int(np.count_nonzero(over))
        np.clip(samples, -ceiling, ceiling, out=samples)
    return samples, scale, clipped


def clip_details(clip_db: float | None, clipped: int) -> dict[str, Any]:
    """The truth's record of the clipping (empty without clipping)."""
    if not clip_db:
        return {}
    return {"clip_db": float(clip_db), "clipped_samples": int(clipped)}


def check_inputs(times: np.ndarray, speeds: np.ndarray, sample_rate: int, channels: int,
                 peak_dbfs: float, clip_db: float | None = None) -> None:
    """Validate a renderer's common arguments (``ValueError`` naming the argument)."""
    if times.ndim != 1 or times.size == 0 or times.shape != speeds.shape:
        raise ValueError("impact_times_s and impact_speeds_m_s must be non-empty 1-D arrays "
                         "of the same length")
    if not (np.all(np.isfinite(times)) and np.all(np.diff(times) >= 0)):
        raise ValueError("impact_times_s must be finite and non-decreasing")
    if not (np.all(np.isfinite(speeds)) and np.all(speeds > 0)):
        raise ValueError("impact_speeds_m_s must be finite and positive")
    if not 8000 <= int(sample_rate) <= 384000 or int(sample_rate) != sample_rate:
        raise ValueError(f"sample_rate must be an integer in [8000, 384000], got {sample_rate!r}")
    if not 1 <= int(channels) <= 8:
        raise ValueError(f"channels must be 1..8, got {channels!r}")
    if not peak_dbfs <= 0:
        raise ValueError(f"peak_dbfs must be <= 0, got {peak_dbfs!r}")
    if clip_db is not None and not 0 <= clip_db <= 60:
        raise ValueError(f"clip_db must be in [0, 60] dB or None, got {clip_db!r}")


def _own_sound(synth, voice, onset, fs, length, click_noise, snare_noise) -> tuple[int, np.ndarray]:
    # Impact alone over `length` samples from its first sample: cheap and exact.
    n0 = int(np.ceil(onset * fs))
    buf = np.zeros(length)
    synth.add_hit(buf, n0, voice, onset, click_noise, snare_noise)
    return n0, buf


def _reference_power(synth, voices, onsets, fs, click_noise, snare_noise) -> float:
    n = max(1, round(REFERENCE_WINDOW_S * fs))
    powers = [np.mean(_own_sound(synth, v, t, fs, n, click_noise, snare_noise)[1] ** 2)
              for v, t in zip(voices, onsets, strict=True)]
    return float(max(powers))


def _local_snr(mix, synth, voices, onsets, fs, click_noise, snare_noise) -> np.ndarray:
    n = max(1, round(LOCAL_SNR_WINDOW_S * fs))
    owns = [_own_sound(synth, v, t, fs, n, click_noise, snare_noise)
            for v, t in zip(voices, onsets, strict=True)]
    return local_snr(mix, owns, fs)


def local_snr(mix: np.ndarray, owns: Sequence[tuple[int, np.ndarray]],
              sample_rate: int) -> np.ndarray:
    """Each impact's local SNR in channel 0 (see the module docstring).

    Parameters
    ----------
    mix
        Channel 0's whole mixture, before scaling.
    owns
        Per impact, its first sample ``n0`` and its own direct sound alone over the
        :data:`LOCAL_SNR_WINDOW_S` from ``n0`` (exactly zero before ``n0``).
    sample_rate
        Samples per second.
    """
    sos = signal.butter(4, LOCAL_SNR_HIGHPASS_HZ, btype="highpass", fs=sample_rate,
                        output="sos")
    mix_hp = signal.sosfilt(sos, mix)
    out = np.empty(len(owns))
    for k, (n0, own) in enumerate(owns):
        # Own sound is zero before n0, so a filter started there from rest is exact.
        own_hp = signal.sosfilt(sos, own)
        other = mix_hp[n0:n0 + len(own)] - own_hp[:len(mix_hp) - n0]
        e_own, e_other = float(np.sum(own_hp**2)), float(np.sum(other**2))
        if e_other == 0:
            out[k] = _SNR_CAP_DB if e_own > 0 else 0.0
        else:
            out[k] = 10 * np.log10(max(e_own, 1e-300) / e_other)
    return np.clip(out, -_SNR_CAP_DB, _SNR_CAP_DB)
