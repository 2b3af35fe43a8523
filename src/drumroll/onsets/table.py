"""The onset table: impact times with their uncertainties, and its file formats.

The CSV header ``time_s,amplitude,snr_db,sigma_s,interval_s`` is a contract other tools read.
:func:`read_onsets` also accepts Audacity label files (``start<TAB>end<TAB>label``) and plain
text with one time per line, so hand-made or third-party onset lists can be fitted too.
"""

from __future__ import annotations

import io
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from drumroll.errors import DrumrollError

#: CSV columns, in order (a contract: do not reorder).
COLUMNS = ("time_s", "amplitude", "snr_db", "sigma_s", "interval_s")


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
        Time since the previous onset (NaN for the first).
    rejected_time_s, rejected_snr_db, rejected_reason
        Candidates the tracker did not keep and why (filled only when asked for).
    source
        Where the onsets came from (a file name, or ``"<array>"``).
    sample_rate
        Sample rate of the recording, if known.
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

    def __post_init__(self) -> None:
        order = np.argsort(np.asarray(self.time_s, dtype=float), kind="stable")
        self.time_s = np.asarray(self.time_s, dtype=float)[order]
        self.amplitude = np.asarray(self.amplitude, dtype=float)[order]
        self.snr_db = np.asarray(self.snr_db, dtype=float)[order]
        self.sigma_s = np.asarray(self.sigma_s, dtype=float)[order]
        self.rejected_time_s = np.asarray(self.rejected_time_s, dtype=float)
        self.rejected_snr_db = np.asarray(self.rejected_snr_db, dtype=float)

    @property
    def interval_s(self) -> np.ndarray:
        """Time since the previous onset (NaN for the first)."""
        return np.concatenate(([np.nan], np.diff(self.time_s))) if len(self) else np.zeros(0)

    def __len__(self) -> int:
        return int(self.time_s.size)

    # -- writing -------------------------------------------------------------------------
    def to_csv(self, *, all_candidates: bool = False) -> str:
        """The table as CSV text with the contract header.

        With ``all_candidates`` the rejected candidates follow the kept onsets as comment lines
        (``# rejected,time_s,snr_db,reason``), which readers of the contract columns skip.
        """
        out = io.StringIO()
        out.write(",".join(COLUMNS) + "\n")
        for row in zip(self.time_s, self.amplitude, self.snr_db, self.sigma_s,
                       self.interval_s, strict=True):
            out.write(",".join(_fmt(v) for v in row) + "\n")
        if all_candidates:
            for t, s, why in zip(self.rejected_time_s, self.rejected_snr_db,
                                 self.rejected_reason, strict=True):
                out.write(f"# rejected,{_fmt(t)},{_fmt(s)},{why}\n")
        return out.getvalue()

    def to_labels(self) -> str:
        """The onsets as an Audacity label track (point labels named ``hit 1``, ``hit 2``…)."""
        return "".join(f"{t:.6f}\t{t:.6f}\thit {i + 1}\n" for i, t in enumerate(self.time_s))

    def to_text(self) -> str:
        """One time per line, seconds."""
        return "".join(f"{t:.7f}\n" for t in self.time_s)


def _fmt(value: float) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "nan"
    return f"{value:.7g}" if abs(value) >= 1e3 or value == 0 else f"{value:.9g}"


# -- reading -------------------------------------------------------------------------------
def read_onsets(path: str | os.PathLike[str]) -> OnsetTable:
    """Read onsets from our CSV, an Audacity label file or a one-time-per-line text file.

    Missing columns are filled in: ``sigma_s`` = 0, ``amplitude`` and ``snr_db`` NaN.

    Raises
    ------
    DrumrollError
        Unreadable file, or a malformed line (the message gives its number).
    """
    path = Path(path)
    if not path.exists():
        raise DrumrollError(f"{path}: no such file")
    if path.is_dir():
        raise DrumrollError(f"{path}: is a directory, expected an onset file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise DrumrollError(f"{path}: cannot read as text ({exc})") from None
    lines = [(n, ln.strip()) for n, ln in enumerate(text.splitlines(), 1)]
    lines = [(n, ln) for n, ln in lines if ln and not ln.startswith("#")]
    if not lines:
        raise DrumrollError(f"{path}: holds no onsets")
    first = lines[0][1]
    if first.replace(" ", "").lower().startswith("time_s"):
        table = _read_csv(path, lines)
    elif "\t" in first:
        table = _read_labels(path, lines)
    else:
        table = _read_plain(path, lines)
    table.source = str(path)
    if table.time_s.size and not np.isfinite(table.time_s).all():
        raise DrumrollError(f"{path}: onset times must be finite numbers")
    if np.any(np.diff(np.sort(table.time_s)) == 0):
        raise DrumrollError(f"{path}: the same onset time appears twice")
    return table


def _number(path: Path, n: int, text: str, what: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise DrumrollError(f"{path}: line {n}: {what} {text.strip()!r} is not a number") \
            from None


def _read_csv(path: Path, lines: list[tuple[int, str]]) -> OnsetTable:
    header = [h.strip() for h in lines[0][1].split(",")]
    missing = [c for c in ("time_s",) if c not in header]
    if missing:
        raise DrumrollError(f"{path}: line {lines[0][0]}: header lacks column time_s")
    cols: dict[str, list[float]] = {c: [] for c in header}
    for n, ln in lines[1:]:
        parts = ln.split(",")
        if len(parts) != len(header):
            raise DrumrollError(f"{path}: line {n}: expected {len(header)} comma-separated "
                                f"values, found {len(parts)}")
        for c, v in zip(header, parts, strict=True):
            cols[c].append(_number(path, n, v, c))
    size = len(cols["time_s"])

    def col(name: str, default: float) -> np.ndarray:
        return np.asarray(cols[name], float) if name in cols else np.full(size, default)

    return OnsetTable(col("time_s", np.nan), col("amplitude", np.nan), col("snr_db", np.nan),
                      col("sigma_s", 0.0))


def _read_labels(path: Path, lines: list[tuple[int, str]]) -> OnsetTable:
    times = []
    for n, ln in lines:
        parts = ln.split("\t")
        if parts[0] == "\\":  # Audacity's spectral-selection continuation line
            continue
        if len(parts) < 2:
            raise DrumrollError(f"{path}: line {n}: expected start<TAB>end<TAB>label")
        times.append(_number(path, n, parts[0], "start time"))
        _number(path, n, parts[1], "end time")
    size = len(times)
    return OnsetTable(np.asarray(times), np.full(size, np.nan), np.full(size, np.nan),
                      np.zeros(size))


def _read_plain(path: Path, lines: list[tuple[int, str]]) -> OnsetTable:
    times = []
    for n, ln in lines:
        if len(ln.split()) != 1:
            raise DrumrollError(f"{path}: line {n}: expected one time per line, found "
                                f"{ln[:40]!r}")
        times.append(_number(path, n, ln, "time"))
    size = len(times)
    return OnsetTable(np.asarray(times), np.full(size, np.nan), np.full(size, np.nan),
                      np.zeros(size))
