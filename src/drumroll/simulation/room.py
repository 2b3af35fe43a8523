"""The room: one strong early reflection (echo) and a reverberant tail.

The room is a linear, time-invariant filter whose impulse response is the direct path (gain
1, no delay) plus a *wet* part: an optional discrete echo (a reflection off the floor or a
nearby wall, slightly low-passed because surfaces absorb high frequencies) and an optional
reverberant tail (noise decaying exponentially with the requested RT60, faster at high
frequencies because of air and wall absorption, starting after a pre-delay and building up
over a few milliseconds). The wet part is convolved with the dry signal by FFT overlap-add.

The wet part never starts before the direct sound, so an impact's first sample is still the
first sample of its sound in the mixture.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

#: Band edges (Hz) of the reverberation's frequency-dependent decay.
_REVERB_BANDS_HZ = (500.0, 2000.0, 6000.0)


@dataclass(frozen=True)
class Room:
    """Acoustics between the drum and the microphone.

    Parameters
    ----------
    echo
        Add one discrete reflection.
    echo_delay_s
        Range ``(low, high)`` the echo's delay after the direct sound is drawn from, once per
        recording (each further channel's delay differs by up to ±0.3 ms).
    echo_gain
        Amplitude of the echo relative to the direct sound.
    echo_cutoff_hz
        The reflection's low-pass cutoff (absorption of high frequencies by the surface).
    reverb_time_s
        RT60 at low frequencies (time for the tail to fall by 60 dB); 0 means a dry room.
    direct_to_reverb_db
        Energy of the direct impulse over the energy of the reverberant tail (a close
        microphone in a small room: about 5-10 dB; across a room: below 0).
    reverb_predelay_s
        Gap between the direct sound and the start of the tail.
    hf_damping
        RT60 above about 6 kHz as a fraction of the low-frequency RT60 (intermediate bands
        interpolate); 1 means no extra high-frequency absorption.
    """

    echo: bool = False
    echo_delay_s: tuple[float, float] = (0.005, 0.015)
    echo_gain: float = 0.5
    echo_cutoff_hz: float = 6000.0
    reverb_time_s: float = 0.0
    direct_to_reverb_db: float = 6.0
    reverb_predelay_s: float = 0.008
    hf_damping: float = 0.5

    def __post_init__(self) -> None:
        lo, hi = self.echo_delay_s
        if not 0.0005 <= lo <= hi:
            raise ValueError(f"Room.echo_delay_s must be (low, high) with 0.5 ms <= low <= high, "
                             f"got {self.echo_delay_s!r}")
        if not 0 <= self.echo_gain <= 1:
            raise ValueError(f"Room.echo_gain must be in [0, 1], got {self.echo_gain!r}")
        if not self.echo_cutoff_hz > 0:
            raise ValueError(f"Room.echo_cutoff_hz must be > 0, got {self.echo_cutoff_hz!r}")
        if not 0 <= self.reverb_time_s <= 10:
            raise ValueError(f"Room.reverb_time_s must be in [0, 10] s, "
                             f"got {self.reverb_time_s!r}")
        if not self.reverb_predelay_s >= 0:
            raise ValueError(f"Room.reverb_predelay_s must be >= 0, "
                             f"got {self.reverb_predelay_s!r}")
        if not 0 < self.hf_damping <= 1:
            raise ValueError(f"Room.hf_damping must be in (0, 1], got {self.hf_damping!r}")
        if not np.isfinite(self.direct_to_reverb_db):
            raise ValueError("Room.direct_to_reverb_db must be finite")


@dataclass(frozen=True)
class RoomResponse:
    """One channel's drawn room: the wet impulse response and the echo's delay."""

    wet: np.ndarray
    echo_delay_s: float | None


def draw_echo_delay(room: Room, rng: np.random.Generator) -> float | None:
    """The recording's echo delay (seconds), or ``None`` without an echo."""
    if not room.echo:
        return None
    return float(rng.uniform(*room.echo_delay_s))


def room_response(room: Room, sample_rate: int, rng: np.random.Generator,
                  echo_delay_s: float | None) -> RoomResponse:
    """Draw the wet impulse response (everything but the direct path) of one channel.

    Parameters
    ----------
    room
        The room.
    sample_rate
        Samples per second.
    rng
        Source of the reverberation's noise (independent per channel: diffuse field).
    echo_delay_s
        This channel's echo delay, or ``None``.

    Returns
    -------
    RoomResponse
        ``wet[n]`` is the response at ``n / sample_rate`` after the direct sound.
    """
    fs = float(sample_rate)
    parts: list[np.ndarray] = []
    if echo_delay_s is not None and room.echo_gain > 0:
        # Windowed-sinc low-pass centred on the (fractional) delay: band-limited, so the
        # reflection can fall between samples; 2 ms of half-width is far less than the delay.
        half = int(min(0.002, echo_delay_s / 2) * fs)
        n = np.arange(int(echo_delay_s * fs) - half, int(echo_delay_s * fs) + half + 1)
        x = n - echo_delay_s * fs
        fc = min(room.echo_cutoff_hz, 0.45 * fs) / fs
        taps = 2 * fc * np.sinc(2 * fc * x) * np.kaiser(len(n), 8.0)
        echo = np.zeros(n[-1] + 1)
        echo[n] = room.echo_gain * taps / taps.sum()
        parts.append(echo)
    if room.reverb_time_s > 0:
        parts.append(_reverb_tail(room, fs, rng))
    if not parts:
        return RoomResponse(np.zeros(0), echo_delay_s)
    wet = np.zeros(max(len(p) for p in parts))
    for p in parts:
        wet[:len(p)] += p
    return RoomResponse(wet, echo_delay_s)


def _reverb_tail(room: Room, fs: float, rng: np.random.Generator) -> np.ndarray:
    rt = room.reverb_time_s
    length = int((room.reverb_predelay_s + 1.2 * rt) * fs) + 1  # to about -72 dB
    t = np.arange(length) / fs - room.reverb_predelay_s
    edges = [f for f in _REVERB_BANDS_HZ if f < 0.45 * fs]
    # RT60 per band, interpolated in log frequency from 1 (lowest) to hf_damping (highest).
    rts = rt * room.hf_damping ** (np.arange(len(edges) + 1) / max(len(edges), 1))
    noise = rng.standard_normal(length)
    tail = np.zeros(length)
    on = t >= 0
    t_on = np.where(on, t, 0.0)
    build_up = -np.expm1(-t_on / 0.004)  # reflection density grows over a few ms
    for i, band_rt in enumerate(rts):
        if i == 0:
            sos = signal.butter(4, edges[0], btype="lowpass", fs=fs, output="sos")
        elif i == len(edges):
            sos = signal.butter(4, edges[-1], btype="highpass", fs=fs, output="sos")
        else:
            sos = signal.butter(4, (edges[i - 1], edges[i]), btype="bandpass", fs=fs,
                                output="sos")
        # Zero-phase band split of the noise; the envelope applied afterwards keeps it causal.
        band = signal.sosfiltfilt(sos, noise)
        tail += band * np.exp(-np.log(1000.0) * t_on / band_rt)
    tail *= on * build_up
    energy = float(np.sum(tail**2))
    if energy > 0:
        tail *= np.sqrt(10 ** (-room.direct_to_reverb_db / 10) / energy)
    return tail


def apply_room(dry: np.ndarray, response: RoomResponse) -> np.ndarray:
    """The microphone signal: ``dry`` plus its convolution with the wet response.

    Samples before the first non-zero dry sample are left exactly zero (FFT convolution
    would otherwise spread round-off of order 1e-16 there).
    """
    if len(response.wet) == 0 or not np.any(dry):
        return dry.copy()
    wet = signal.oaconvolve(dry, response.wet)[:len(dry)]
    first = int(np.argmax(dry != 0))
    wet[:first] = 0.0
    return dry + wet
