"""The sound of one drumstick impact on a snare drum.

The drumhead is a damped circular membrane: its modes sit at the zeros of the Bessel
functions, ``f_mn = f_01 j_mn / j_01`` (ratios 1, 1.594, 2.136, 2.296, 2.653, ...), each
excited according to where the stick lands and ringing with its own decay time (higher
modes die faster). Angular modes (m > 0) are split slightly by uneven tension, so they beat
as on a real drum. The stick pushes on the head for a finite time: the force is a half-sine
pulse, convolved *analytically* with every mode's damped sinusoid, so the waveform can be
evaluated at any instant and a hit can start between two samples without a fractional-delay
filter (no pre-ringing, no leakage before the impact). On top of the modes sit the stick's
own click (the contact pulse, a few bending modes of the wooden stick and a short broadband
burst) and the snare wires' rattle (band-limited noise, delayed by the trip across the
shell, buzzing at the head's fundamental and needing a minimum speed to get going).

Truth convention
----------------
The impact time ``t_k`` is the first instant of contact. The sound of hit k is exactly zero
at every sample instant before ``t_k``; the first sample at or after ``t_k`` carries the start
of the contact. Propagation from the drum to the microphone is not modelled (equivalently,
the truth is the arrival time at the first channel's microphone).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from scipy import signal, special

#: Decay of a component (in e-folds) after which its contribution is dropped (-104 dB).
_EFOLDS = 12.0


@functools.lru_cache(maxsize=8)
def membrane_modes(n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Frequency ratios and angular orders of an ideal circular membrane's first modes.

    Parameters
    ----------
    n_modes
        Number of modes, lowest first.

    Returns
    -------
    ratios, orders
        ``j_mn / j_01`` and ``m`` for the ``n_modes`` lowest modes (read-only arrays).
    """
    zeros = sorted((z, m) for m in range(n_modes + 1) for z in special.jn_zeros(m, n_modes))
    z, m = (np.array(v) for v in zip(*zeros[:n_modes], strict=True))
    ratios, orders = z / z[0], m.astype(int)
    ratios.flags.writeable = orders.flags.writeable = False
    return ratios, orders


@dataclass(frozen=True)
class DrumSound:
    """A drum struck by a stick; the defaults are a 14-inch snare and a wooden stick.

    Parameters
    ----------
    fundamental_hz
        Frequency of the membrane's (0,1) mode.
    decay_s
        Amplitude time constant of the (0,1) mode; mode i decays with
        ``decay_s * ratio_i ** -mode_decay_exponent``.
    snare_level
        Peak level of the snare-wire rattle relative to the membrane's modes.
    click_level
        Level of the stick's own click (contact pulse, stick modes, broadband burst).
    contact_time_s
        Duration of the half-sine contact force at the reference speed; it scales as
        ``speed ** contact_exponent`` (Hertzian contact: faster impacts are shorter).
    loudness_exponent
        Amplitude is proportional to ``(speed / reference_speed_m_s) ** loudness_exponent``.
    reference_speed_m_s
        Impact speed at which the levels above hold.
    n_modes
        Number of membrane modes rendered.
    mode_ratios
        Frequency ratios of the modes; ``None`` means the ideal membrane's Bessel-zero ratios.
    mode_decay_exponent
        How much faster higher modes decay (see ``decay_s``).
    strike_position
        Where the stick lands, as a fraction of the head's radius from its centre.
    strike_jitter
        Hit-to-hit scatter of ``strike_position`` (the tip does not land on one point).
    mode_split
        Relative frequency splitting of the degenerate (m > 0) mode pairs; makes them beat.
    pitch_glide
        Relative pitch rise at the start of a hit at the reference speed (tension modulation:
        a loud hit starts sharp and glides down); scales with speed squared.
    brightness_exponent
        Extra gain ``(speed / reference) ** (brightness_exponent * (1 - 1/ratio))`` of the higher
        modes, and ``(speed / reference) ** brightness_exponent`` of the click and snare.
    contact_exponent
        Exponent of the contact time's speed dependence (Hertz: -1/5).
    snare_band_hz
        Pass band of the snare rattle (clipped to 0.45 of the sample rate).
    snare_decay_s
        Amplitude time constant of the rattle (0.06 s: it is 60 dB down after about 0.4 s).
    snare_delay_s
        Time for the impact to reach the snare-side head and lift the wires.
    snare_threshold_m_s
        Impact speed below which the wires barely buzz (they need the head to out-accelerate
        them); the rattle's level falls by ``v**2 / (v**2 + threshold**2)``.
    snare_modulation
        Depth of the rattle's modulation at the head's fundamental (wires slap once a cycle).
    click_decay_s
        Time constant of the click's broadband burst.
    stick_modes_hz
        Bending-mode frequencies of the (pivoted) stick, heard in the click.
    stick_decay_s
        Time constant of the stick modes.
    hit_variation_db
        Hit-to-hit scatter (standard deviation) of each part's level.
    """

    fundamental_hz: float = 200.0
    decay_s: float = 0.25
    snare_level: float = 0.5
    click_level: float = 0.3
    contact_time_s: float = 0.8e-3
    loudness_exponent: float = 1.3
    reference_speed_m_s: float = 1.0
    n_modes: int = 12
    mode_ratios: tuple[float, ...] | None = None
    mode_decay_exponent: float = 1.0
    strike_position: float = 0.35
    strike_jitter: float = 0.02
    mode_split: float = 0.004
    pitch_glide: float = 0.01
    brightness_exponent: float = 0.3
    contact_exponent: float = -0.2
    snare_band_hz: tuple[float, float] = (2000.0, 10000.0)
    snare_decay_s: float = 0.06
    snare_delay_s: float = 0.5e-3
    snare_threshold_m_s: float = 0.05
    snare_modulation: float = 0.6
    click_decay_s: float = 1.0e-3
    stick_modes_hz: tuple[float, ...] = (950.0, 1870.0, 3090.0, 4620.0)
    stick_decay_s: float = 0.015
    hit_variation_db: float = 0.7

    def contact_times(self, speeds: np.ndarray) -> np.ndarray:
        """How long each impact at tip ``speeds`` (m/s) holds the stick on the head (s): the
        half-sine force's duration, ``contact_time_s`` at the reference speed scaled as
        ``speed ** contact_exponent`` (Hertz), kept within 0.1-10 ms. The sound's contact
        pulse lasts this long, and the next flight starts when it ends
        (:func:`~drumroll.simulation.settings.true_impacts`)."""
        rel = np.asarray(speeds, dtype=float) / self.reference_speed_m_s
        return np.clip(self.contact_time_s * rel ** self.contact_exponent, 0.1e-3, 10e-3)

    def __post_init__(self) -> None:
        positive = ("fundamental_hz", "decay_s", "contact_time_s", "reference_speed_m_s",
                    "snare_decay_s", "click_decay_s", "stick_decay_s")
        non_negative = ("snare_level", "click_level", "loudness_exponent", "mode_decay_exponent",
                        "strike_jitter", "mode_split", "pitch_glide", "brightness_exponent",
                        "snare_delay_s", "snare_threshold_m_s", "hit_variation_db")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"DrumSound.{name} must be > 0, got {getattr(self, name)!r}")
        for name in non_negative:
            if not getattr(self, name) >= 0:
                raise ValueError(f"DrumSound.{name} must be >= 0, got {getattr(self, name)!r}")
        if not 1 <= self.n_modes <= 60:
            raise ValueError(f"DrumSound.n_modes must be 1..60, got {self.n_modes!r}")
        if self.mode_ratios is not None and (len(self.mode_ratios) != self.n_modes
                                             or min(self.mode_ratios) <= 0):
            raise ValueError("DrumSound.mode_ratios must hold n_modes positive ratios")
        if not 0 <= self.strike_position < 1:
            raise ValueError(f"DrumSound.strike_position must be in [0, 1), "
                             f"got {self.strike_position!r}")
        if not 0 <= self.snare_modulation <= 1:
            raise ValueError(f"DrumSound.snare_modulation must be in [0, 1], "
                             f"got {self.snare_modulation!r}")
        lo, hi = self.snare_band_hz
        if not 0 < lo < hi:
            raise ValueError(f"DrumSound.snare_band_hz must be (low, high) with 0 < low < high, "
                             f"got {self.snare_band_hz!r}")
        if any(f <= 0 for f in self.stick_modes_hz):
            raise ValueError("DrumSound.stick_modes_hz must be positive")


@dataclass(frozen=True)
class Voice:
    """Everything about one impact that the drum alone does not fix (drawn per hit)."""

    speed: float
    contact_s: float
    mode_amps: np.ndarray = field(repr=False)  # per component, loudness and brightness included
    stick_amp: float
    click_amp: float
    snare_amp: float
    glide: float


class ImpactSynth:
    """Renders impacts of one drum at one sample rate.

    Every component is a damped sinusoid driven by the half-sine contact force; its free
    decay after the contact is read from a precomputed table ``exp(s n / fs)`` so a hit costs
    a multiply-add per sample and component, however many hits overlap.

    Parameters
    ----------
    drum
        The instrument.
    sample_rate
        Samples per second.
    """

    def __init__(self, drum: DrumSound, sample_rate: int) -> None:
        self.drum, self.fs = drum, float(sample_rate)
        ratios, orders = membrane_modes(drum.n_modes)
        if drum.mode_ratios is not None:
            ratios = np.asarray(drum.mode_ratios, dtype=float)
        nyquist_ok = ratios * drum.fundamental_hz < 0.45 * self.fs
        self._ratios, self._orders = ratios[nyquist_ok], orders[nyquist_ok]
        # Degenerate (m > 0) pairs are split by uneven tension: two components, half each.
        split = self._orders > 0
        mode_idx = np.concatenate([np.arange(len(self._ratios)), np.flatnonzero(split)])
        detune = np.ones(len(mode_idx))
        detune[np.flatnonzero(split)] = 1 + drum.mode_split / 2
        detune[len(self._ratios):] = 1 - drum.mode_split / 2
        self._mode_of = mode_idx
        self._mode_weight = np.where(self._orders[mode_idx] > 0, 0.5, 1.0)
        mode_f = drum.fundamental_hz * self._ratios[mode_idx] * detune
        mode_tau = drum.decay_s * self._ratios[mode_idx] ** -drum.mode_decay_exponent
        stick_f = np.array([f for f in drum.stick_modes_hz if f < 0.45 * self.fs])
        self._n_mode_comps = len(mode_f)
        self._stick_w = 1.0 / (1.0 + np.arange(len(stick_f)))
        freqs = np.concatenate([mode_f, stick_f])
        taus = np.concatenate([mode_tau, np.full(len(stick_f), drum.stick_decay_s)])
        self._s = -1.0 / taus + 2j * np.pi * freqs
        self._tables = [np.exp(s * np.arange(int(np.ceil(_EFOLDS * tau * self.fs))) / self.fs)
                        for s, tau in zip(self._s, taus, strict=True)]
        self._norm = 1.0 / np.linalg.norm(self._excitation(drum.strike_position))
        self._snare_band = (drum.snare_band_hz[0], min(drum.snare_band_hz[1], 0.45 * self.fs))
        self.extent = max([len(t) for t in self._tables]
                          + [int((drum.snare_delay_s + _EFOLDS * drum.snare_decay_s) * self.fs),
                             int(_EFOLDS * drum.click_decay_s * self.fs)]) + 2

    def _excitation(self, r: float) -> np.ndarray:
        # Modal amplitude at strike radius r (mode shape J_m over its norm), times a pressure
        # weight: radiation grows with frequency, falls with angular order (multipoles).
        z = special.jn_zeros(0, 1)[0] * self._ratios
        shape = special.jv(self._orders, z * r) / np.abs(special.jv(self._orders + 1, z))
        return shape * self._ratios / (1.0 + self._orders)

    def voices(self, speeds: np.ndarray, rng: np.random.Generator) -> list[Voice]:
        """Draw the per-hit scatter (levels, strike point) for impacts at ``speeds`` (m/s)."""
        d = self.drum
        out = []
        for v in np.asarray(speeds, dtype=float):
            rel = v / d.reference_speed_m_s
            loud = rel ** d.loudness_exponent
            gains = 10 ** (d.hit_variation_db * rng.standard_normal(4) / 20)
            r = float(np.clip(d.strike_position + d.strike_jitter * rng.standard_normal(),
                              0.0, 0.95))
            bright = rel ** (d.brightness_exponent * (1 - 1 / self._ratios))
            per_mode = self._excitation(r) * self._norm * bright * loud * gains[0]
            bright_hf = rel ** d.brightness_exponent
            snare_gate = v**2 / (v**2 + d.snare_threshold_m_s**2)
            out.append(Voice(
                speed=float(v),
                contact_s=float(d.contact_times(v)),
                mode_amps=per_mode[self._mode_of] * self._mode_weight,
                stick_amp=d.click_level * loud * bright_hf * gains[1],
                click_amp=d.click_level * loud * bright_hf * gains[2],
                snare_amp=d.snare_level * loud * bright_hf * snare_gate * gains[3],
                glide=d.pitch_glide * rel**2,
            ))
        return out

    def noise_streams(self, n_frames: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        """Unit-RMS band-limited noise for the click bursts and the snare wires, whole file.

        The snare wires are one system: overlapping hits re-excite the same rattle, so they
        share a stream, each hit enveloping it; clicks (a few ms) never overlap in practice.
        """
        click_band = (1000.0, min(12000.0, 0.45 * self.fs))
        streams = []
        for band, child in zip((click_band, self._snare_band), rng.spawn(2), strict=True):
            sos = signal.butter(4, band, btype="bandpass", fs=self.fs, output="sos")
            x = signal.sosfilt(sos, child.standard_normal(n_frames + 4096))[4096:]
            # Scale by the filter's noise gain, not the realised RMS, so that a hit sounds
            # the same whatever the file's length.
            impulse = np.zeros(8192)
            impulse[0] = 1.0
            streams.append(x / np.sqrt(np.sum(signal.sosfilt(sos, impulse) ** 2)))
        return streams[0], streams[1]

    def add_hit(self, out: np.ndarray, base: int, voice: Voice, onset_s: float,
                click_noise: np.ndarray, snare_noise: np.ndarray) -> None:
        """Add one impact's sound to ``out``, which holds file samples ``base ...``.

        Parameters
        ----------
        out
            Buffer of file samples ``base`` to ``base + len(out) - 1``; modified in place.
        base
            File index of ``out[0]``; may be after the onset (the hit is cut to the buffer).
        voice
            The hit's drawn parameters (see :meth:`voices`).
        onset_s
            Impact time in the file, seconds; nothing is added before it.
        click_noise, snare_noise
            The streams from :meth:`noise_streams`, indexed by file sample.
        """
        fs = self.fs
        n0 = int(np.ceil(onset_s * fs))
        lo, hi = max(n0, base), min(n0 + self.extent, base + len(out))
        if hi <= lo:
            return
        tc = voice.contact_s
        beta = np.pi / tc
        amps = np.concatenate([voice.mode_amps, voice.stick_amp * self._stick_w])
        # Tension modulation follows the squared amplitude: time constant decay_s / 2.
        tau_g = self.drum.decay_s / 2
        for i, (s, a, table) in enumerate(zip(self._s, amps, self._tables, strict=True)):
            end = min(hi, n0 + len(table))
            if end <= lo or a == 0:
                continue
            n_contact = min(end, max(lo, int(np.ceil((onset_s + tc) * fs))))
            if n_contact > lo:  # during contact: the exact convolution integral
                t = np.maximum(np.arange(lo, n_contact) / fs - onset_s, 0.0)
                est = np.exp(s * t)
                resp = (beta / 2) * ((np.exp(1j * beta * t) - est) / (2j * (1j * beta - s))
                                     - (np.exp(-1j * beta * t) - est) / (2j * (-1j * beta - s)))
                out[lo - base:n_contact - base] += a * resp.imag
            start = max(lo, n_contact)
            if start >= end:
                continue
            k = (beta**2 / 2) * (1 + np.exp(-s * tc)) / (s**2 + beta**2)
            # Glide: phase s.imag * G * tau_g * (1 - exp(-t / tau_g)), followed exactly while the
            # component is loud (2 of its own time constants, at most 3 tau_g), then frozen
            # (continuous phase; the remaining pitch offset is below 0.3 % of G).
            excursion = s.imag * voice.glide * tau_g if i < self._n_mode_comps else 0.0
            t_freeze = min(3 * tau_g, -2 / s.real) if excursion > 0.05 else 0.0
            g_end = min(end, max(start, n0 + int(t_freeze * fs)))
            frozen = excursion * -np.expm1(-t_freeze / tau_g)
            if g_end > start:
                t = np.arange(start, g_end) / fs - onset_s
                glide = excursion * -np.expm1(-np.minimum(t, t_freeze) / tau_g)
                out[start - base:g_end - base] += a * (k * np.exp(s * t + 1j * glide)).imag
            if g_end < end:
                c = a * k * np.exp(s * (g_end / fs - onset_s) + 1j * frozen)
                seg = table[:end - g_end]
                out[g_end - base:end - base] += c.real * seg.imag + c.imag * seg.real
        self._add_noises(out, base, lo, hi, n0, voice, onset_s, click_noise, snare_noise)

    def _add_noises(self, out, base, lo, hi, n0, voice, onset_s, click_noise, snare_noise):
        d, fs, tc = self.drum, self.fs, voice.contact_s
        # The contact force itself (the head's local, non-modal give) and the stick's burst.
        c_hi = min(hi, n0 + int((tc + _EFOLDS * d.click_decay_s) * fs) + 2)
        if c_hi > lo and voice.click_amp > 0:
            t = np.maximum(np.arange(lo, c_hi) / fs - onset_s, 0.0)
            pulse = np.where(t < tc, np.sin(np.pi * np.minimum(t, tc) / tc), 0.0)
            burst = -np.expm1(-t / (tc / 3)) * np.exp(-t / d.click_decay_s)
            out[lo - base:c_hi - base] += voice.click_amp * (0.5 * pulse
                                                             + burst * click_noise[lo:c_hi])
        s_lo = max(lo, int(np.ceil((onset_s + d.snare_delay_s) * fs)))
        s_hi = min(hi, n0 + int((d.snare_delay_s + _EFOLDS * d.snare_decay_s) * fs) + 2)
        if s_hi > s_lo and voice.snare_amp > 0:
            ts = np.maximum(np.arange(s_lo, s_hi) / fs - onset_s - d.snare_delay_s, 0.0)
            buzz = (1 + d.snare_modulation * np.cos(2 * np.pi * d.fundamental_hz * ts)) \
                / (1 + d.snare_modulation)
            env = -np.expm1(-ts / 1e-3) * np.exp(-ts / d.snare_decay_s) * buzz
            out[s_lo - base:s_hi - base] += voice.snare_amp * env * snare_noise[s_lo:s_hi]
