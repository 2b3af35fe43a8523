"""A measured room: the reflections and reverberation of a recorded impulse response.

A measured impulse response holds, in order, a little silence (and the measurement's
pre-ringing), the direct sound from the loudspeaker, and then what the room adds: early
reflections and the reverberant tail. The dry sound of a recorded hit already holds its
own direct sound, so only what the room adds is kept:

* the response's start is its first sample within 20 dB of its peak (the onset of
  ISO 3382-1), and its direct sound is the largest sample in the 1 ms after that start
  (usually the global peak; not when a reflection is louder than the direct path, as in
  the bundled live room, whose first arrival is 3 dB below a later one);
* the direct sound itself is taken to last :data:`DIRECT_SOUND_S` (1 ms) after its peak:
  the loudspeaker's and microphone's own impulse responses die away within that time in
  the bundled responses, and a reflection less than 1 ms (34 cm of path) behind the direct
  sound is part of a close-miked drum's own sound anyway;
* the *wet* response is everything after that, indexed by lag from the direct sound (zero
  below 1 ms).

The microphone then hears ``dry + g (wet * dry)`` (``*`` is convolution, by FFT
overlap-add), and since the wet response is zero below 1 ms, nothing of it precedes the dry
sound. The gain ``g`` is set once per recording (so the room stays one linear,
time-invariant filter) such that the energy of ``g (wet * dry)`` is ``wet_db`` relative to
the energy of ``dry`` (channel 0, over the whole recording): ``wet_db`` means what it says
whatever the sample rate and the instrument. (Normalising the response's own energy
instead would not: a room's response holds most of its energy at low frequencies, where a
drum's sound is too, so the same response would sound 6 dB louder at 96 kHz than at
22.05 kHz, where the empty band above 11 kHz holds none of its energy.)
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from drumroll.simulation.sample_files import read_mono

#: How long the measured response's own direct sound lasts after its peak.
DIRECT_SOUND_S = 1.0e-3
#: The response's start: its first sample within this many dB of its peak (ISO 3382-1).
ONSET_DB = -20.0
#: The direct sound is the largest sample within this time after the start.
DIRECT_SEARCH_S = 1.0e-3


@dataclass(frozen=True, eq=False)
class MeasuredRoom:
    """A measured room's reflections and reverberation, ready to convolve.

    Build it with :meth:`load`.

    Attributes
    ----------
    wet
        The wet response: ``wet[n]`` is the room's answer ``n`` samples after the direct
        sound (zero for ``n`` below :data:`DIRECT_SOUND_S`), scaled to unit energy (its level
        is set by :meth:`gain`).
    sample_rate
        Samples per second of ``wet``.
    name
        The response's file as the user named it (for the truth).
    wet_db
        Energy of the reflections and reverberation relative to the dry sound (dB).
    direct_s
        Where the direct sound lies in the file (seconds).
    """

    wet: np.ndarray = field(repr=False)
    sample_rate: int
    name: str
    wet_db: float
    direct_s: float

    @classmethod
    def load(cls, path: str | os.PathLike[str], sample_rate: int, *, wet_db: float = -12.0,
             name: str | None = None) -> MeasuredRoom:
        """Read an impulse response and keep what follows its direct sound.

        Parameters
        ----------
        path
            The impulse response (any recording :mod:`drumroll.audio` reads; channels are
            averaged).
        sample_rate
            Rate to resample to (the rendering's).
        wet_db
            Energy of the reflections and reverberation relative to the dry sound (dB).
        name
            How to name the file in the truth (default: the path as given).

        Raises
        ------
        drumroll.errors.AudioError
            A file that is missing, not audio or damaged (one line naming it).
        ValueError
            A silent response, one with nothing after its direct sound, or a non-finite
            ``wet_db``.
        """
        if not np.isfinite(wet_db) or not -120 <= wet_db <= 40:
            raise ValueError(f"MeasuredRoom.wet_db must be in [-120, 40] dB, got {wet_db!r}")
        h = read_mono(path, sample_rate)
        a = np.abs(h)
        peak = float(a.max()) if a.size else 0.0
        if not peak > 0:
            raise ValueError(f"{path}: the impulse response is silent")
        start = int(np.argmax(a >= 10 ** (ONSET_DB / 20) * peak))
        search = max(1, round(DIRECT_SEARCH_S * sample_rate))
        direct = start + int(np.argmax(a[start:start + search]))
        cut = max(1, round(DIRECT_SOUND_S * sample_rate))
        tail = h[direct + cut:]
        energy = float(np.sum(tail**2))
        if not energy > 0:
            raise ValueError(f"{path}: nothing follows the impulse response's direct sound")
        wet = np.concatenate([np.zeros(cut), tail / np.sqrt(energy)])
        return cls(wet=wet, sample_rate=int(sample_rate),
                   name=str(path) if name is None else name, wet_db=float(wet_db),
                   direct_s=direct / sample_rate)

    def gain(self, dry: np.ndarray, wet: np.ndarray) -> float:
        """The factor that puts ``wet`` (``dry`` convolved with :attr:`wet`) at ``wet_db``.

        Parameters
        ----------
        dry
            Channel 0's dry sound over the whole recording.
        wet
            Its convolution with :attr:`wet`, over the same samples.

        Returns
        -------
        float
            ``g`` with ``sum((g wet)**2) = 10**(wet_db / 10) sum(dry**2)`` (0 for silence).
        """
        e_dry, e_wet = float(np.sum(dry**2)), float(np.sum(wet**2))
        if not (e_dry > 0 and e_wet > 0):
            return 0.0
        return float(np.sqrt(10 ** (self.wet_db / 10) * e_dry / e_wet))

    def truth(self, gain: float) -> dict[str, float | str]:
        """The truth's record of this room in a recording where :meth:`gain` gave ``gain``."""
        return {"file": self.name, "wet_db": self.wet_db, "direct_s": self.direct_s,
                "gain": float(gain)}

    def channel_response(self, delay_samples: int) -> np.ndarray:
        """The wet response of a microphone whose direct sound arrives ``delay_samples`` later.

        The reflections come off the room's walls, which are about as far from a second
        microphone as from the first: they arrive at the same times, so relative to that
        microphone's later direct sound they come ``delay_samples`` earlier. Those that would
        fall within its own direct sound are dropped (nothing precedes the direct sound).
        """
        d = int(delay_samples)
        cut = max(1, round(DIRECT_SOUND_S * self.sample_rate))
        if d <= 0:
            return self.wet
        out = self.wet[d:].copy()
        out[:cut] = 0.0
        return out
