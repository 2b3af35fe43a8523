"""One roll: its onsets, their bounce numbers and what was measured of each.

Every stage after the tracker takes a :class:`Roll` and returns a new one (rolls are
immutable), so the stages compose in the order :data:`drumroll.onsets.detector.STAGES`
lists them.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np


@dataclass(frozen=True)
class Roll:
    """The impacts of one roll, in time order (parallel arrays).

    Attributes
    ----------
    time_s
        Onset times, seconds from the start of the recording.
    bounce
        Bounce number of each onset: 0 for the roll's first impact, one more per impact;
        an impact that was not heard (masked or too faint) leaves a gap.
    amplitude
        Peak absolute value of the high-passed impact sound after the onset.
    snr_db
        The impact's own sound against what it lands in (see
        :attr:`~.refine.Refined.snr_db`).
    sigma_s
        One-standard-deviation timing uncertainty, seconds.
    level
        Loudness the tracker compared (peak of the high-passed sound over the detection
        window after the onset); NaN where not measured.
    """

    time_s: np.ndarray
    bounce: np.ndarray
    amplitude: np.ndarray
    snr_db: np.ndarray
    sigma_s: np.ndarray
    level: np.ndarray

    def __post_init__(self) -> None:
        for f in fields(self):
            kind = np.int64 if f.name == "bounce" else np.float64
            object.__setattr__(self, f.name, np.asarray(getattr(self, f.name), dtype=kind))

    def __len__(self) -> int:
        return int(self.time_s.size)

    @classmethod
    def empty(cls) -> Roll:
        """A roll without onsets."""
        z = np.zeros(0)
        return cls(z, z.astype(np.int64), z, z, z, z)

    def subset(self, index: np.ndarray | slice) -> Roll:
        """The onsets at ``index`` (bounce numbers kept as they are)."""
        return Roll(*(getattr(self, f.name)[index] for f in fields(self)))

    def renumbered(self) -> Roll:
        """The same onsets with bounce numbers counted from the first kept onset."""
        if len(self) == 0:
            return self
        return replace(self, bounce=self.bounce - self.bounce[0])

    def with_onset(self, time_s: float, bounce: int, amplitude: float, snr_db: float,
                   sigma_s: float, level: float = float("nan")) -> Roll:
        """This roll with one more onset after its last: a later bounce at a later time.

        Raises
        ------
        ValueError
            If the onset is not after the last one in both time and bounce number (the
            columns would no longer be in one order).
        """
        if len(self) and not (time_s > self.time_s[-1] and bounce > self.bounce[-1]):
            raise ValueError(f"onset {time_s:.6f} s (bounce {bounce}) is not after the "
                             f"last, {self.time_s[-1]:.6f} s (bounce {self.bounce[-1]})")
        return Roll(*(np.append(getattr(self, f.name), v) for f, v in
                      zip(fields(self), (time_s, bounce, amplitude, snr_db, sigma_s, level),
                          strict=True)))

    def with_times(self, time_s: np.ndarray, amplitude: np.ndarray, snr_db: np.ndarray,
                   sigma_s: np.ndarray) -> Roll:
        """The same bounces timed again."""
        return replace(self, time_s=time_s, amplitude=amplitude, snr_db=snr_db,
                       sigma_s=sigma_s)

    @property
    def gaps(self) -> np.ndarray:
        """Bounce numbers missing between the first and the last onset."""
        if len(self) == 0:
            return np.zeros(0, dtype=np.int64)
        every = np.arange(int(self.bounce[0]), int(self.bounce[-1]) + 1)
        return np.setdiff1d(every, self.bounce)

    def flights(self) -> tuple[np.ndarray, np.ndarray]:
        """Flight times between consecutive bounce numbers (a flight across a gap is not
        one flight), and the bounce number each ends at."""
        consecutive = np.diff(self.bounce) == 1
        return np.diff(self.time_s)[consecutive], self.bounce[1:][consecutive]
