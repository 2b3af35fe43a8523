"""What a real recording adds to the drumroll: room noise, mains hum, stray sounds.

Levels are relative to one reference power, ``P_ref``: the largest, over the impacts, of the
mean square of an impact's own dry sound (first channel, full band) in the 10 ms after its
onset. Background noise has mean power ``P_ref * 10**(-snr_db / 10)`` over the file; hum
has mean power ``P_ref * 10**(hum_db / 10)``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import fft as sp_fft
from scipy import signal

from drumroll.simulation.sounds import DrumSound

#: Length of the window after an onset whose mean square defines the reference power.
REFERENCE_WINDOW_S = 0.010


@dataclass(frozen=True)
class Disturbances:
    """Noise, hum and spurious events, and the silence around the roll.

    Parameters
    ----------
    snr_db
        Background noise: ``10 log10(P_ref / P_noise)`` with ``P_ref`` as in the module
        docstring and ``P_noise`` the noise's mean square over the file; ``None`` for none.
    noise_slope_db_per_octave
        Spectral slope of the noise's power (-3 is pink, 0 white, -6 brown), above 20 Hz.
    noise_floor_db
        A white floor (microphone and preamplifier self-noise) added to the sloped spectrum,
        in dB relative to the sloped part's power density at 1 kHz.
    noise_fluctuation_db
        Standard deviation of the noise's slow level wander (ventilation, traffic), in dB.
    hum_hz
        Mains frequency (50 or 60) or ``None`` for no hum.
    hum_db
        Hum power relative to ``P_ref``, harmonics included.
    hum_harmonics
        Number of harmonics (odd ones dominate, as from a rectifier or ground loop).
    spurious
        Add a tap 0.2-1 s before the roll and a handling knock after the roll has faded;
        both are reported as spurious events.
    lead_in_s
        Silence (noise only) before the first impact; lengthened so that a tap lands at
        least 0.2 s after the start of the file.
    tail_s
        Recording time after the last impact; lengthened if a knock must fit in.
    """

    snr_db: float | None = 40.0
    noise_slope_db_per_octave: float = -3.0
    noise_floor_db: float = -12.0
    noise_fluctuation_db: float = 1.0
    hum_hz: float | None = None
    hum_db: float = -30.0
    hum_harmonics: int = 8
    spurious: bool = False
    lead_in_s: float = 0.5
    tail_s: float = 1.0

    def __post_init__(self) -> None:
        if self.snr_db is not None and not -20 <= self.snr_db <= 140:
            raise ValueError(f"Disturbances.snr_db must be in [-20, 140] dB or None, "
                             f"got {self.snr_db!r}")
        if not -12 <= self.noise_slope_db_per_octave <= 6:
            raise ValueError("Disturbances.noise_slope_db_per_octave must be in [-12, 6], "
                             f"got {self.noise_slope_db_per_octave!r}")
        if not self.noise_fluctuation_db >= 0:
            raise ValueError("Disturbances.noise_fluctuation_db must be >= 0")
        if self.hum_hz is not None and not 10 <= self.hum_hz <= 1000:
            raise ValueError(f"Disturbances.hum_hz must be in [10, 1000] Hz or None, "
                             f"got {self.hum_hz!r}")
        if not 1 <= self.hum_harmonics <= 50:
            raise ValueError(f"Disturbances.hum_harmonics must be 1..50, "
                             f"got {self.hum_harmonics!r}")
        if not self.lead_in_s >= 0 or not self.tail_s >= 0:
            raise ValueError("Disturbances.lead_in_s and tail_s must be >= 0")
        for name in ("noise_floor_db", "hum_db"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"Disturbances.{name} must be finite")


def background_noise(n_frames: int, sample_rate: int, dist: Disturbances,
                     rng: np.random.Generator) -> np.ndarray:
    """Unit-RMS coloured noise with a slowly wandering level.

    The spectrum is ``(f / 1 kHz) ** (slope / 3.01) + floor`` in power, flat below 20 Hz; the
    level wanders with a 0.5 Hz low-passed Gaussian process of ``noise_fluctuation_db``.
    """
    if n_frames == 0:
        return np.zeros(0)
    n_fft = sp_fft.next_fast_len(n_frames, real=True)  # long primes make FFTs crawl
    spectrum = sp_fft.rfft(rng.standard_normal(n_fft))
    f = np.maximum(sp_fft.rfftfreq(n_fft, 1.0 / sample_rate), 20.0)
    power = (f / 1000.0) ** (dist.noise_slope_db_per_octave / (10 * np.log10(2.0))) \
        + 10 ** (dist.noise_floor_db / 10)
    x = sp_fft.irfft(spectrum * np.sqrt(power), n_fft)[:n_frames]
    if dist.noise_fluctuation_db > 0 and n_frames > 1:
        x *= 10 ** (dist.noise_fluctuation_db * _slow_wander(n_frames, sample_rate, rng) / 20)
    else:
        rng.standard_normal(1)  # keep the stream of draws independent of the option
    return x / max(float(np.sqrt(np.mean(x**2))), 1e-300)


def _slow_wander(n_frames: int, sample_rate: int, rng: np.random.Generator) -> np.ndarray:
    # A unit-variance process with ~2 s correlation, made at 100 Hz and interpolated.
    n_slow = int(n_frames / sample_rate * 100) + 8
    sos = signal.butter(2, 0.5, fs=100.0, output="sos")
    slow = signal.sosfiltfilt(sos, rng.standard_normal(n_slow + 400))[200:-200]
    slow /= max(float(np.std(slow)), 1e-12)
    return np.interp(np.arange(n_frames) / sample_rate * 100.0, np.arange(n_slow), slow)


def mains_hum(n_frames: int, sample_rate: int, dist: Disturbances,
              rng: np.random.Generator) -> np.ndarray:
    """Unit-RMS mains hum: harmonics of ``hum_hz`` (odd ones stronger), random phases.

    The mains frequency drifts by about 0.02 % during the recording, as a grid does.
    """
    t = np.arange(n_frames) / sample_rate
    drift = 1 + 2e-4 * np.sin(2 * np.pi * t / rng.uniform(20, 60) + rng.uniform(0, 2 * np.pi))
    rotor = np.exp(2j * np.pi * dist.hum_hz * np.cumsum(drift) / sample_rate)
    x = np.zeros(n_frames)
    harmonic = np.ones(n_frames, dtype=complex)
    for h in range(1, dist.hum_harmonics + 1):
        if h * dist.hum_hz >= 0.45 * sample_rate:
            break
        harmonic *= rotor  # e^{i h phase} by repeated multiplication: no per-harmonic exp
        level = (1.0 if h % 2 else 0.3) / h
        x += level * (harmonic * np.exp(1j * rng.uniform(0, 2 * np.pi))).imag
    return x / max(float(np.sqrt(np.mean(x**2))), 1e-300)


@dataclass(frozen=True)
class SpuriousEvent:
    """A sound that is not an impact of the roll.

    ``time_s`` is relative to the roll's first impact (negative before it).
    """

    time_s: float
    kind: str
    speed_m_s: float
    drum: DrumSound


def plan_spurious(drum: DrumSound, first_speed: float, last_impact_s: float,
                  rng: np.random.Generator) -> list[SpuriousEvent]:
    """Draw a tap before the roll and a handling knock after it.

    The tap (the stick or a finger touching the head while the stick is set up) lands
    0.2-1 s before the first impact at 20-50 % of its speed. The knock (catching the stick,
    a hand on the head) comes once the roll's ringing has fallen by about 40 dB; it is
    muffled: a long contact, a heavily damped head, little snare.
    """
    tap = SpuriousEvent(
        time_s=-float(rng.uniform(0.2, 1.0)), kind="tap",
        speed_m_s=first_speed * float(rng.uniform(0.2, 0.5)),
        drum=replace(drum, contact_time_s=2.0e-3, click_level=0.5 * drum.click_level),
    )
    fade = max(0.3, 4.6 * drum.decay_s)
    knock = SpuriousEvent(
        time_s=last_impact_s + fade + float(rng.uniform(0.0, 0.3)), kind="knock",
        speed_m_s=first_speed * float(rng.uniform(0.3, 0.8)),
        drum=replace(drum, decay_s=min(drum.decay_s, 0.04), contact_time_s=6.0e-3,
                     click_level=0.2 * drum.click_level, snare_level=0.3 * drum.snare_level,
                     pitch_glide=0.0),
    )
    return [tap, knock]
