"""The onset table: impact times with their uncertainties and bounce numbers.

The CSV header ``time_s,amplitude,snr_db,sigma_s,interval_s,bounce,roll`` is a contract other
tools read (columns are only ever appended, never reordered). ``bounce`` numbers the impacts
of a roll (physics.md: k = 0 for the first impact, flight k between impacts k − 1 and k); an
impact that was not heard leaves a gap in the numbers. ``roll`` numbers the rolls of one
recording (0, 1, 2, … in time order), when a stick was dropped more than once.

The files it is read from and written to are :mod:`drumroll.onsets.formats`.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drumroll.errors import DrumrollError

#: CSV columns, in order (a contract: append new ones, never reorder).
COLUMNS = ("time_s", "amplitude", "snr_db", "sigma_s", "interval_s", "bounce", "roll")
#: The columns that number the onsets (whole numbers, not measurements).
NUMBER_COLUMNS = ("bounce", "roll")
#: An Audacity label that carries the numbers: ``hit n`` or ``roll m hit n`` (from 1).


@dataclass
class OnsetTable:
    """Detected impacts, one row each, sorted by time.

    Attributes
    ----------
    time_s
        Impact times from the start of the recording, seconds.
    amplitude
        Peak absolute value of the high-passed impact click (full scale = 1); NaN if unknown.
    snr_db
        Local signal-to-noise ratio: the impact's own sound (energy over the 2 ms after the
        onset, prediction of the ring before it removed) against the sound already there, dB.
    sigma_s
        One-standard-deviation timing uncertainty of each onset, seconds (0 if unknown).
    interval_s
        Time since the previous onset of the same roll (NaN for each roll's first).
    rejected_time_s, rejected_snr_db, rejected_reason
        Candidates the tracker did not keep and why (filled only when asked for).
    source
        Where the onsets came from (a file name, or ``"<array>"``).
    sample_rate
        Sample rate of the recording, if known.
    channel
        The channel (0-based) the onsets were timed on, where a recording has several
        (the one that hears the impacts first); None for one channel or unknown.
    bounce
        Bounce number k of each onset within its roll (keyword; ``None``: 0, 1, 2, … in time
        order within each roll). Strictly increasing with time within a roll; a missing number
        is an impact that was not heard (inaudible or masked).
    roll
        Roll number of each onset (keyword; ``None``: all 0): 0, 1, 2, … in time order.

    Raises
    ------
    ValueError
        Columns of different lengths, or numbers that break the rules above.
    """

    time_s: np.ndarray
    amplitude: np.ndarray
    snr_db: np.ndarray
    sigma_s: np.ndarray
    rejected_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rejected_snr_db: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rejected_reason: list[str] = field(default_factory=list)
    source: str = ""
    sample_rate: int | None = None
    channel: int | None = field(default=None, kw_only=True)
    bounce: np.ndarray | None = field(default=None, kw_only=True)
    roll: np.ndarray | None = field(default=None, kw_only=True)

    def __post_init__(self) -> None:
        time_s = np.asarray(self.time_s, dtype=float).ravel()
        order = np.argsort(time_s, kind="stable")
        self.time_s = time_s[order]
        for name in ("amplitude", "snr_db", "sigma_s"):
            values = np.asarray(getattr(self, name), dtype=float).ravel()
            if values.size != order.size:
                raise ValueError(f"{name} has {values.size} values for {order.size} onsets")
            setattr(self, name, values[order])
        self.roll = (np.zeros(order.size, dtype=np.int64) if self.roll is None
                     else _whole_numbers(self.roll, "roll", order.size)[order])
        self.bounce = (count_within(self.roll) if self.bounce is None
                       else _whole_numbers(self.bounce, "bounce", order.size)[order])
        problem = numbering_problem(self.bounce, self.roll)
        if problem is not None:
            raise ValueError(f"onset {problem[0]} (in time order): {problem[1]}")
        self.rejected_time_s = np.asarray(self.rejected_time_s, dtype=float)
        self.rejected_snr_db = np.asarray(self.rejected_snr_db, dtype=float)

    @property
    def interval_s(self) -> np.ndarray:
        """Time since the previous onset of the same roll (NaN for each roll's first).

        Across a gap in the bounce numbers this spans several flights (see
        :func:`single_flights`).
        """
        if not len(self):
            return np.zeros(0)
        same_roll = self.roll[1:] == self.roll[:-1]
        return np.concatenate(([np.nan], np.where(same_roll, np.diff(self.time_s), np.nan)))

    def __len__(self) -> int:
        return int(self.time_s.size)

    # -- rolls and gaps ------------------------------------------------------------------
    @property
    def rolls(self) -> tuple[int, ...]:
        """The roll numbers present, in time order."""
        return tuple(int(r) for r in np.unique(self.roll))

    def roll_sizes(self) -> dict[int, int]:
        """Number of onsets of each roll present, in time order."""
        numbers, counts = np.unique(self.roll, return_counts=True)
        return {int(r): int(c) for r, c in zip(numbers, counts, strict=True)}

    @property
    def longest_roll(self) -> int:
        """The roll with the most onsets (the earliest of those tied).

        Raises
        ------
        ValueError
            For an empty table.
        """
        sizes = self.roll_sizes()
        if not sizes:
            raise ValueError("an empty onset table has no rolls")
        return max(sizes, key=lambda r: (sizes[r], -r))

    def select_roll(self, number: int) -> OnsetTable:
        """The onsets of roll ``number`` alone (bounce and roll numbers kept).

        (Named ``select_roll``, not ``roll``: ``roll`` is the column of roll numbers.)

        Raises
        ------
        DrumrollError
            If the table holds no roll ``number``.
        """
        if number not in self.rolls:
            where = f"{self.source}: " if self.source else ""
            present = ", ".join(map(str, self.rolls)) or "none"
            raise DrumrollError(f"{where}no roll {number}; the onsets hold "
                                f"roll{'s' if len(self.rolls) != 1 else ''} {present}")
        keep = self.roll == number
        return replace(self, time_s=self.time_s[keep], amplitude=self.amplitude[keep],
                       snr_db=self.snr_db[keep], sigma_s=self.sigma_s[keep],
                       bounce=self.bounce[keep], roll=self.roll[keep],
                       rejected_reason=list(self.rejected_reason))

    def gaps(self, roll: int | None = None) -> list[int]:
        """The bounce numbers missing between the first and the last onset of one roll.

        Parameters
        ----------
        roll
            The roll; ``None`` for the table's only roll.

        Raises
        ------
        ValueError
            ``roll`` is None and the table holds several rolls.
        """
        if roll is None:
            if len(self.rolls) > 1:
                raise ValueError(f"the table holds rolls {', '.join(map(str, self.rolls))}: "
                                 "say which roll's gaps")
            bounces = self.bounce
        else:
            bounces = self.bounce[self.roll == roll]
        return missing_bounces(bounces)

    # -- saying what it holds --------------------------------------------------------------
    def describe(self) -> str:
        """One line on what was found: each roll's impacts, span and unheard bounces, and
        the channel timed on (``16 impacts from 1.0896 s to 2.9303 s``)."""
        if not len(self):
            return "no impacts"
        rolls = []
        for n in self.rolls:
            roll = self.select_roll(n)
            gaps = self.gaps(n)
            missing = f", bounce{'s' if len(gaps) > 1 else ''} {', '.join(map(str, gaps))} " \
                "unheard" if gaps else ""
            rolls.append(f"{len(roll)} impacts from {roll.time_s[0]:.4f} s to "
                         f"{roll.time_s[-1]:.4f} s{missing}")
        text = rolls[0] if len(rolls) == 1 else \
            f"{len(rolls)} rolls: " + "; ".join(f"roll {n}: {r}" for n, r in enumerate(rolls))
        if self.channel is not None:
            text += f" (timed on channel {self.channel + 1}, which hears the impacts first)"
        return text

    def __repr__(self) -> str:
        source = f" of {self.source}" if self.source else ""
        return f"<OnsetTable{source}: {self.describe()}>"

    # The rich displays of a notebook are the reporting layer's (imported only when shown,
    # so that reading onsets never loads it).
    def _repr_html_(self) -> str:
        from drumroll.reporting.display import onsets_display, to_html

        return to_html(onsets_display(self))

    def _repr_markdown_(self) -> str:
        from drumroll.reporting.display import onsets_display, to_markdown

        return to_markdown(onsets_display(self, figure=False))

    # -- writing -------------------------------------------------------------------------
    def to_csv(self, *, all_candidates: bool = False) -> str:
        """The table as CSV text with the contract header (:data:`COLUMNS`).

        With ``all_candidates`` the rejected candidates follow the kept onsets as comment lines
        (``# rejected,time_s,snr_db,reason``), which readers of the contract columns skip.
        """
        out = io.StringIO()
        out.write(",".join(COLUMNS) + "\n")
        for *row, bounce, roll in zip(self.time_s, self.amplitude, self.snr_db, self.sigma_s,
                                      self.interval_s, self.bounce, self.roll, strict=True):
            out.write(",".join([*(_fmt(v) for v in row), str(int(bounce)), str(int(roll))])
                      + "\n")
        if all_candidates:
            for t, s, why in zip(self.rejected_time_s, self.rejected_snr_db,
                                 self.rejected_reason, strict=True):
                out.write(f"# rejected,{_fmt(t)},{_fmt(s)},{why}\n")
        return out.getvalue()

    def label_names(self) -> list[str]:
        """Each onset's label: ``hit n`` for bounce n − 1 (``hit 1``, ``hit 2``, … when no
        bounce is missing), prefixed ``roll m`` for roll m − 1 when the table holds any roll
        but roll 0, and followed by ``, sd x ms``, the onset's timing error, where it has one
        (read back as ``sigma_s``)."""
        prefix = bool(np.any(self.roll != 0))

        def error(sigma: float) -> str:
            return f", sd {1e3 * sigma:.4f} ms" if np.isfinite(sigma) and sigma > 0 else ""

        return [f"{f'roll {r + 1} ' if prefix else ''}hit {k + 1}{error(s)}"
                for k, r, s in zip(self.bounce, self.roll, self.sigma_s, strict=True)]

    def to_labels(self) -> str:
        """The onsets as an Audacity label track of point labels (:meth:`label_names`)."""
        return "".join(f"{t:.6f}\t{t:.6f}\t{name}\n"
                       for t, name in zip(self.time_s, self.label_names(), strict=True))

    def to_text(self) -> str:
        """One time per line, seconds (no bounce or roll numbers: one roll, no gaps)."""
        return "".join(f"{t:.7f}\n" for t in self.time_s)


def missing_bounces(bounces: ArrayLike) -> list[int]:
    """The numbers missing between the first and the last of increasing ``bounces``."""
    bounces = np.asarray(bounces, dtype=np.int64)
    if bounces.size < 2:
        return []
    return [int(k) for k in np.setdiff1d(np.arange(bounces[0], bounces[-1] + 1), bounces)]


def numbering_problem(bounce: NDArray, roll: NDArray) -> tuple[int, str] | None:
    """The first row (in time order) whose bounce or roll number breaks the contract, and
    what is wrong with it; None when every number is fine.

    The rules: numbers are non-negative; rolls are numbered in time order (no roll starts
    before an earlier-numbered one ends); within a roll, bounce numbers increase with time.
    """
    for name, values in (("bounce", bounce), ("roll", roll)):
        negative = np.flatnonzero(values < 0)
        if negative.size:
            i = int(negative[0])
            return i, f"{name} {int(values[i])} is negative (numbers count from 0)"
    earlier = np.flatnonzero(np.diff(roll) < 0)
    if earlier.size:
        i = int(earlier[0]) + 1
        return i, (f"roll {int(roll[i])} after roll {int(roll[i - 1])}: rolls are numbered in "
                   "time order")
    same = roll[1:] == roll[:-1]
    back = np.flatnonzero(same & (np.diff(bounce) <= 0))
    if back.size:
        i = int(back[0]) + 1
        return i, (f"bounce {int(bounce[i])} after bounce {int(bounce[i - 1])} of roll "
                   f"{int(roll[i])}: bounce numbers must increase with time within a roll")
    return None


def _whole_numbers(values: ArrayLike, name: str, size: int) -> NDArray[np.int64]:
    """``values`` as int64, checked to be ``size`` whole numbers."""
    values = np.asarray(values).ravel()
    if values.size != size:
        raise ValueError(f"{name} has {values.size} values for {size} onsets")
    if values.dtype.kind not in "iu":
        as_float = values.astype(float)
        if not np.all(np.isfinite(as_float) & (as_float == np.round(as_float))):
            raise ValueError(f"{name} numbers must be whole numbers")
        values = as_float
    return values.astype(np.int64)


def count_within(roll: NDArray) -> NDArray[np.int64]:
    """0, 1, 2, … within each roll of ``roll`` (sorted by time)."""
    count = np.arange(roll.size, dtype=np.int64)
    if roll.size:
        starts = np.flatnonzero(np.r_[True, roll[1:] != roll[:-1]])
        count -= np.repeat(starts, np.diff(np.r_[starts, roll.size]))
    return count


def _fmt(value: float) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "nan"
    return f"{value:.7g}" if abs(value) >= 1e3 or value == 0 else f"{value:.9g}"


def single_flights(bounces: ArrayLike, rolls: ArrayLike | None = None) -> NDArray[np.intp]:
    """Indices i ≥ 1 of the onsets that end one whole flight.

    Onset i ends flight k = ``bounces[i]`` (physics.md: flight k lies between impacts k − 1
    and k) when onset i − 1 is bounce k − 1 (of the same roll, when ``rolls`` are given); then
    t_i − t_{i−1} is T_k. Across a missing bounce the time between two onsets spans several
    flights and is no flight: every figure and table of flight times leaves it out.
    """
    bounces = np.asarray(bounces, dtype=np.int64)
    ends = np.diff(bounces) == 1
    if rolls is not None:
        rolls = np.asarray(rolls)
        ends &= rolls[1:] == rolls[:-1]
    return np.flatnonzero(ends) + 1
