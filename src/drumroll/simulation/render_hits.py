"""Mix a drumroll recording from recorded hits, with known truth.

Each impact is a recorded hit of a :class:`~drumroll.simulation.hits.HitBank`, in the
velocity layer and at the level its speed calls for, placed so that the sample's start (its
own first sound, see :mod:`drumroll.simulation.hits`) lands on the impact; overlapping hits
add linearly. Recorded :class:`ExtraHit` sounds that are not impacts (a side-stick tap
before the roll, a tom after it) may be added. The dry sum goes through a room (synthetic
:class:`~drumroll.simulation.room.Room` or measured
:class:`~drumroll.simulation.measured_room.MeasuredRoom`), then background noise and hum
(levels as in :mod:`drumroll.simulation.disturbances`) are added, and the file is scaled or
clipped (:func:`~drumroll.simulation.render.level_and_clip`).

Truth conventions are those of :mod:`drumroll.simulation.render`, with one difference: a
sample's start is a sample, so each impact is placed on the nearest sample of the file and
``impact_times_s`` are those sample instants (at most half a sample from the requested time
plus the lead-in). Channel 0 is exactly zero before an impact's time, up to the sounds
before it. The local SNR is computed as there, from the impact's own dry hit alone.

Further channels are microphones farther from the drum: the direct sound arrives 0.3-2 ms
later (10-70 cm farther) and 1-6 dB weaker, while the room's reflections, which come off
walls about as far from either microphone, keep their times and level: the farther
microphone is more reverberant. Each channel has its own background noise; the hum is
common to all.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import signal

from drumroll.simulation.disturbances import (
    REFERENCE_WINDOW_S,
    Disturbances,
    background_noise,
    mains_hum,
)
from drumroll.simulation.hits import HitBank
from drumroll.simulation.measured_room import MeasuredRoom
from drumroll.simulation.render import (
    LOCAL_SNR_WINDOW_S,
    Rendering,
    check_inputs,
    clip_details,
    level_and_clip,
    local_snr,
)
from drumroll.simulation.room import Room, draw_echo_delay, room_response

#: Further channels: range of the direct sound's extra delay (s) and its gain (dB).
FAR_DELAY_S = (0.3e-3, 2.0e-3)
FAR_GAIN_DB = (-6.0, -1.0)
#: An extra hit before the roll lands at least this long after the start of the file.
_MIN_LEAD_S = 0.2
#: The file is lengthened to hold this much of an extra hit after the roll.
_EXTRA_TAIL_S = 0.5


@dataclass(frozen=True, eq=False)
class ExtraHit:
    """A recorded sound that is not an impact of the roll (reported as a spurious event).

    Parameters
    ----------
    sound
        The sound; its loudest layer is used.
    time_s
        When its sample's start lands: seconds after the roll's first impact (negative:
        before the roll) or, with ``after_last``, after its last impact.
    after_last
        Count ``time_s`` from the last impact instead of the first.
    level_db
        Its level relative to the roll's loudest impact (0 dB); the same 10 ms RMS
        normalisation as the roll's hits.
    kind
        Its name in the truth (default: the file's name).
    """

    sound: HitBank
    time_s: float
    after_last: bool = False
    level_db: float = 0.0
    kind: str = ""

    def __post_init__(self) -> None:
        if not np.isfinite(self.time_s) or (self.after_last and self.time_s < 0):
            raise ValueError(f"ExtraHit.time_s must be finite (and >= 0 after the last "
                             f"impact), got {self.time_s!r}")
        if not np.isfinite(self.level_db):
            raise ValueError(f"ExtraHit.level_db must be finite, got {self.level_db!r}")


_ROOM, _DISTURBANCES = Room(), Disturbances()


def render_hits(impact_times_s: ArrayLike, impact_speeds_m_s: ArrayLike, *, bank: HitBank,
                room: Room | MeasuredRoom = _ROOM,
                disturbances: Disturbances = _DISTURBANCES, channels: int = 1,
                extra_hits: Sequence[ExtraHit] = (), rng: np.random.Generator,
                peak_dbfs: float = -1.0, clip_db: float | None = None) -> Rendering:
    """Render a drumroll recording from recorded hits, with known impact times.

    Parameters
    ----------
    impact_times_s
        Impact times (seconds, non-decreasing), relative to any origin; the origin is placed
        ``lead_in_s`` after the start of the file.
    impact_speeds_m_s
        Tip speed at each impact (m/s, positive): sets each hit's level and layer.
    bank
        The recorded hits; its sample rate is the recording's.
    room
        A synthetic room, or a measured one at the bank's sample rate.
    disturbances
        Noise, hum, lead-in and tail; its synthetic ``spurious`` events are not available
        here (use ``extra_hits``).
    channels
        Number of channels (1-8); channel 0 is the close microphone that holds the truth.
    extra_hits
        Recorded sounds that are not impacts.
    rng
        All randomness comes from here: the same generator state gives the same recording.
    peak_dbfs, clip_db
        Final level and optional clipping (see
        :func:`~drumroll.simulation.render.level_and_clip`).

    Returns
    -------
    Rendering
        Samples and truth; ``details["recorded_hits"]`` holds the files, each impact's layer
        (0 = softest) and its nominal and drawn levels (dB re the loudest impact).
    """
    times = np.asarray(impact_times_s, dtype=float)
    speeds = np.asarray(impact_speeds_m_s, dtype=float)
    fs = bank.sample_rate
    check_inputs(times, speeds, fs, channels, peak_dbfs, clip_db)
    _check_sources(fs, room, disturbances, extra_hits)
    r_level, r_room, r_noise, r_hum, r_chan = rng.spawn(5)

    layers, nominal_db, level_db = bank.plan(speeds, r_level)
    extra_t = np.array([x.time_s + (times[-1] - times[0] if x.after_last else 0.0)
                        for x in extra_hits])
    lead = disturbances.lead_in_s
    end = times[-1] + disturbances.tail_s
    for t in extra_t:  # before the roll: not at the file's very start; after it: room to ring
        lead = max(lead, _MIN_LEAD_S - (times[0] + t))
        end = max(end, times[0] + t + _EXTRA_TAIL_S)
    n_frames = int(np.ceil((lead + end) * fs)) + 1
    starts = np.round((times + lead) * fs).astype(int)
    extra_starts = np.round((lead + times[0] + extra_t) * fs).astype(int)

    hits = [(n0, 10 ** (lv / 20) * bank.layers[i])
            for n0, lv, i in zip(starts, level_db, layers, strict=True)]
    extras = [(n0, 10 ** (x.level_db / 20) * x.sound.layers[-1])
              for n0, x in zip(extra_starts, extra_hits, strict=True)]
    dry = np.zeros(n_frames)
    for n0, sound in (*hits, *extras):
        m = min(len(sound), n_frames - n0)
        dry[n0:n0 + m] += sound[:m]

    n_ref = max(1, round(REFERENCE_WINDOW_S * fs))
    p_ref = max(float(np.sum(sound[:n_ref] ** 2)) / n_ref for _, sound in hits)
    delays = np.concatenate([[0], np.round(r_chan.uniform(*FAR_DELAY_S, channels - 1) * fs)
                             ]).astype(int)
    gains = np.concatenate([[1.0], 10 ** (r_chan.uniform(*FAR_GAIN_DB, channels - 1) / 20)])
    responses, echoes = _responses(room, fs, channels, delays, r_room)
    hum = (np.sqrt(p_ref * 10 ** (disturbances.hum_db / 10))
           * mains_hum(n_frames, fs, disturbances, r_hum)) if disturbances.hum_hz else 0.0
    wet_gain = 1.0
    mixes = []
    for c in range(channels):
        wet = _wet(dry, responses[c])
        if isinstance(room, MeasuredRoom):
            if c == 0:  # one gain for every channel: the room is one filter
                wet_gain = room.gain(dry, wet)
            wet *= wet_gain
        heard = gains[c] * dry + wet
        mix = np.zeros(n_frames)
        mix[delays[c]:] = heard[:n_frames - delays[c]]
        mix += hum
        if disturbances.snr_db is not None:
            mix += np.sqrt(p_ref * 10 ** (-disturbances.snr_db / 10)) \
                * background_noise(n_frames, fs, disturbances, r_noise)
        mixes.append(mix)

    n_snr = max(1, round(LOCAL_SNR_WINDOW_S * fs))
    owns = [(int(n0), _window(sound, n_snr)) for n0, sound in hits]
    local = local_snr(mixes[0], owns, fs)
    samples = mixes[0] if channels == 1 else np.stack(mixes, axis=1)
    samples, scale, clipped = level_and_clip(samples, peak_dbfs, clip_db)
    details: dict[str, object] = {"truth_convention": (
        "impact_times_s: the sample instant where each impact's recorded hit begins (its "
        "sample's first sound), seconds from the file's first sample, channel 0; nothing of "
        "an impact's sound precedes it"), "recorded_hits": {
        "files": list(bank.names),
        "sample_starts_s": [float(s) for s in bank.starts_s],
        "layer_db": bank.layer_db, "level_exponent": bank.level_exponent,
        "level_spread_db": bank.level_spread_db,
        "impact_layers": [int(i) for i in layers],
        "impact_nominal_levels_db": [float(v) for v in nominal_db],
        "impact_levels_db": [float(v) for v in level_db],
        "extra_hits": [{"file": x.sound.names[-1], "kind": _kind(x),
                        "time_s": float(n0 / fs), "level_db": x.level_db}
                       for x, n0 in zip(extra_hits, extra_starts, strict=True)],
    }}
    if isinstance(room, MeasuredRoom):
        details["measured_room"] = room.truth(wet_gain)
    details.update(clip_details(clip_db, clipped))
    return Rendering(
        samples=samples, sample_rate=fs, impact_times_s=starts / fs,
        impact_speeds_m_s=speeds.copy(), local_snr_db=local,
        spurious_times_s=extra_starts / fs,
        spurious_kinds=tuple(_kind(x) for x in extra_hits), scale=scale, lead_in_s=float(lead),
        reference_power=p_ref, echo_delay_s=echoes,
        channel_delays_s=tuple(float(d / fs) for d in delays),
        channel_gains=tuple(float(g) for g in gains), details=details,
    )


def _check_sources(fs: int, room: Room | MeasuredRoom, disturbances: Disturbances,
                   extra_hits: Sequence[ExtraHit]) -> None:
    if isinstance(room, MeasuredRoom) and room.sample_rate != fs:
        raise ValueError(f"the measured room is at {room.sample_rate} Hz, the hits at {fs} Hz")
    for x in extra_hits:
        if x.sound.sample_rate != fs:
            raise ValueError(f"extra hit {x.sound.names[-1]} is at {x.sound.sample_rate} Hz, "
                             f"the hits at {fs} Hz")
    if disturbances.spurious:
        raise ValueError("Disturbances.spurious makes synthetic events; with recorded hits "
                         "give extra_hits instead")


def _responses(room: Room | MeasuredRoom, fs: int, channels: int, delays: np.ndarray,
               rng: np.random.Generator
               ) -> tuple[list[np.ndarray], tuple[float, ...] | None]:
    """Each channel's wet response, by lag from its own direct sound, and the echo delays."""
    if isinstance(room, MeasuredRoom):
        return [room.channel_response(int(d)) for d in delays], None
    echo0 = draw_echo_delay(room, rng)
    echoes = None if echo0 is None else (echo0, *(float(e) for e in np.maximum(
        echo0 + rng.uniform(-0.3e-3, 0.3e-3, channels - 1), 0.5e-3)))
    # A synthetic tail is drawn per channel: independent diffuse fields.
    return [room_response(room, fs, rng, None if echoes is None else echoes[c]).wet
            for c in range(channels)], echoes


def _wet(dry: np.ndarray, response: np.ndarray) -> np.ndarray:
    """``dry`` convolved with a wet response, exactly zero before the first dry sound."""
    if len(response) == 0 or not np.any(dry):
        return np.zeros_like(dry)
    wet = signal.oaconvolve(dry, response)[:len(dry)]
    wet[:int(np.argmax(dry != 0))] = 0.0  # FFT round-off, 1e-16, would precede the sound
    return wet


def _window(sound: np.ndarray, n: int) -> np.ndarray:
    """The first ``n`` samples of ``sound``, zero-padded if it is shorter."""
    out = np.zeros(n)
    out[:min(n, len(sound))] = sound[:n]
    return out


def _kind(extra: ExtraHit) -> str:
    if extra.kind:
        return extra.kind
    name = extra.sound.names[-1].replace("\\", "/").rsplit("/", 1)[-1]
    return name.rsplit(".", 1)[0] if "." in name else name
