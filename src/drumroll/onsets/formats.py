"""The onset file formats, each registered once with its suffixes, how its first line is
recognised, its reader and its writer (:data:`ONSET_FORMATS`).

* ``csv``: our CSV, header ``time_s,amplitude,snr_db,sigma_s,interval_s,bounce,roll`` (a
  contract other tools read: columns are only ever appended, never reordered). A CSV without
  ``bounce`` and ``roll`` (as written before they existed) is one roll numbered 0, 1, 2, ….
* ``labels``: an Audacity label track (``start<TAB>end<TAB>label``). Labels named ``hit n``
  (what :meth:`~drumroll.onsets.table.OnsetTable.to_labels` writes) carry bounce n − 1, and
  ``roll m hit n`` roll m − 1 as well (labels count from 1, as people do); when any label is
  named otherwise, the labels are numbered in time order. A label's ``, sd x ms`` is its
  onset's timing error ``sigma_s``, so that onsets edited in Audacity keep their weights in
  the fit (a faint onset's error is several times a loud one's); a label without it (one
  added by hand) has none but the fitted jitter.
* ``instants``: a time-instants layer as Sonic Visualiser exports it, ``time,label`` lines
  under a ``TIME,LABEL`` header row or none (also a ``.csv``: told from ours by its first
  line); the labels are read as the label track's are.
* ``text``: one time per line, seconds; one roll numbered 0, 1, 2, …

so that hand-made and third-party onset lists can be fitted too. A number may be written with
a decimal comma (``0,1265``), as spreadsheets in many languages write it, wherever a comma
cannot be the separator: a CSV separated by semicolons or tabs (or of one column), a label
track, one time per line.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drumroll.errors import DrumrollError, DrumrollWarning
from drumroll.onsets.table import (
    NUMBER_COLUMNS,
    OnsetTable,
    count_within,
    numbering_problem,
)

_LABEL = re.compile(r"^(?:roll\s+(\d+)\s+)?hit\s+(\d+)"
                    r"(?:\s*,?\s*sd\s+(\d+(?:\.\d*)?(?:e[-+]?\d+)?)\s*ms)?$", re.IGNORECASE)

#: A reader: the file's path (for messages) and its numbered, non-empty, non-comment lines.
Reader = Callable[[Path, list[tuple[int, str]]], OnsetTable]


@dataclass(frozen=True)
class OnsetFormat:
    """One onset file format.

    Attributes
    ----------
    name
        Its name (``csv``, ``labels``, ``instants``, ``text``).
    description
        What it is, in a few words.
    suffixes
        File suffixes that name an onset file of this format (lower case, with the dot).
    recognises
        Whether a file whose first content line is the argument is in this format.
    read
        Its reader.
    write
        Its writer: an onset table as the file's text.
    """

    name: str
    description: str
    suffixes: tuple[str, ...]
    recognises: Callable[[str], bool]
    read: Reader
    write: Callable[[OnsetTable], str]


def read_onsets(path: str | os.PathLike[str]) -> OnsetTable:
    """Read onsets in any of :data:`ONSET_FORMATS`, recognised by the file's first line.

    Missing columns are filled in: ``sigma_s`` = 0, ``amplitude`` and ``snr_db`` NaN,
    ``bounce`` 0, 1, 2, … within each roll and ``roll`` 0. The bounce and roll numbers are
    checked (whole, non-negative, bounces increasing with time within a roll, rolls numbered
    in time order).

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
    fmt = next(f for f in ONSET_FORMATS.values() if f.recognises(lines[0][1]))
    table = fmt.read(path, lines)
    table.source = str(path)
    if table.time_s.size and not np.isfinite(table.time_s).all():
        raise DrumrollError(f"{path}: onset times must be finite numbers")
    if np.any(table.time_s < 0):
        raise DrumrollError(f"{path}: onset time {table.time_s.min():g} s is negative: times "
                            "are seconds from the start of the recording")
    if np.any(np.diff(np.sort(table.time_s)) == 0):
        raise DrumrollError(f"{path}: the same onset time appears twice")
    sigma = np.asarray(table.sigma_s, float)
    if sigma.size and not (np.isfinite(sigma).all() and np.all(sigma >= 0)):
        bad = sigma[~(np.isfinite(sigma) & (sigma >= 0))][0]
        raise DrumrollError(f"{path}: sigma_s {bad:g} is not a timing error (a standard "
                            "deviation in seconds: finite, 0 or more)")
    return table


#: A number written with a decimal comma, as spreadsheets and text in many languages write
#: it (``0,1265``): one comma between digits, nothing else that could separate two values.
_DECIMAL_COMMA = re.compile(r"^\s*[-+]?\d+,\d+(?:[eE][-+]?\d+)?\s*$")


def _number(path: Path, n: int, text: str, what: str) -> float:
    if _DECIMAL_COMMA.match(text):  # never a separator here: the line was split before
        text = text.replace(",", ".")
    try:
        return float(text)
    except ValueError:
        raise DrumrollError(f"{path}: line {n}: {what} {text.strip()!r} is not a number") \
            from None


def _whole(path: Path, n: int, text: str, what: str) -> int:
    """A bounce or roll number of line ``n``: a non-negative whole number (``3`` or ``3.0``)."""
    value = _number(path, n, text, what)
    if not (math.isfinite(value) and value == round(value)):
        raise DrumrollError(f"{path}: line {n}: {what} {text.strip()!r} is not a whole number")
    if value < 0:
        raise DrumrollError(f"{path}: line {n}: {what} {text.strip()} is negative (numbers "
                            "count from 0)")
    return int(value)


def _numbered(path: Path, line_numbers: list[int], times: list[float], columns: dict
              ) -> OnsetTable:
    """The table of ``times`` with the numbering columns given (``bounce``, ``roll`` or
    neither), after checking the numbers against each other; an error names the line."""
    times_a = np.asarray(times, float)
    back = np.flatnonzero(np.diff(times_a) < 0)
    if back.size:  # read in time order all the same, but a user should know
        warnings.warn(f"{path}: line {line_numbers[back[0] + 1]}: onset "
                      f"{times_a[back[0] + 1]:g} s comes before the line above it "
                      f"({times_a[back[0]]:g} s); the onsets are read in time order",
                      DrumrollWarning, stacklevel=4)
    bounce, roll = columns.get("bounce"), columns.get("roll")
    if bounce is not None or roll is not None:
        order = np.argsort(times_a, kind="stable")
        roll_sorted = (np.zeros(order.size, np.int64) if roll is None
                       else np.asarray(roll, np.int64)[order])
        bounce_sorted = (count_within(roll_sorted) if bounce is None
                         else np.asarray(bounce, np.int64)[order])
        problem = numbering_problem(bounce_sorted, roll_sorted)
        if problem is not None:
            row, message = problem
            raise DrumrollError(f"{path}: line {line_numbers[order[row]]}: {message}")
    size = times_a.size
    return OnsetTable(times_a, columns.get("amplitude", np.full(size, np.nan)),
                      columns.get("snr_db", np.full(size, np.nan)),
                      columns.get("sigma_s", np.zeros(size)), bounce=bounce, roll=roll)


#: Column separators of a CSV, as spreadsheets write it: the first in its header wins (a
#: spreadsheet set to a language with decimal commas writes ";").
CSV_SEPARATORS = {",": "comma", ";": "semicolon", "\t": "tab"}


def _read_csv(path: Path, lines: list[tuple[int, str]]) -> OnsetTable:
    separator = next((s for s in CSV_SEPARATORS if s in lines[0][1]), ",")
    header = [h.strip() for h in lines[0][1].split(separator)]
    missing = [c for c in ("time_s",) if c not in header]
    if missing:
        raise DrumrollError(f"{path}: line {lines[0][0]}: header lacks column time_s")
    cols: dict[str, list[float]] = {c: [] for c in header}
    for n, ln in lines[1:]:
        # One column: a comma in a row can only be its decimal comma (0,1265).
        parts = ln.split(separator) if len(header) > 1 else [ln]
        if len(parts) != len(header):
            raise DrumrollError(f"{path}: line {n}: expected {len(header)} "
                                f"{CSV_SEPARATORS[separator]}-separated values, found "
                                f"{len(parts)}")
        for c, v in zip(header, parts, strict=True):
            cols[c].append(_whole(path, n, v, c) if c in NUMBER_COLUMNS
                           else _number(path, n, v, c))
    given = {c: np.asarray(cols[c], np.int64 if c in NUMBER_COLUMNS else float)
             for c in ("amplitude", "snr_db", "sigma_s", *NUMBER_COLUMNS) if c in cols}
    return _numbered(path, [n for n, _ in lines[1:]], cols["time_s"], given)


def _read_labels(path: Path, lines: list[tuple[int, str]]) -> OnsetTable:
    times, names, line_numbers = [], [], []
    for n, ln in lines:
        parts = ln.split("\t")
        if parts[0] == "\\":  # Audacity's spectral-selection continuation line
            continue
        if len(parts) < 2:
            raise DrumrollError(f"{path}: line {n}: expected start<TAB>end<TAB>label")
        times.append(_number(path, n, parts[0], "start time"))
        _number(path, n, parts[1], "end time")
        names.append(parts[2].strip() if len(parts) > 2 else "")
        line_numbers.append(n)
    return _labelled(path, line_numbers, times, names)


def _labelled(path: Path, line_numbers: list[int], times: list[float], names: list[str]
              ) -> OnsetTable:
    """The table of ``times`` whose labels are ``names``: labels ``[roll m] hit n[, sd x ms]``
    (every one of them) carry the numbers and timing errors; others are numbered in time
    order."""
    matches = [_LABEL.match(name) for name in names]
    columns: dict[str, np.ndarray] = {}
    if matches and all(matches):  # every label carries its numbers: keep them
        for n, m in zip(line_numbers, matches, strict=True):
            if int(m.group(2)) < 1 or (m.group(1) is not None and int(m.group(1)) < 1):
                raise DrumrollError(f"{path}: line {n}: label {m.group(0)!r}: hits and rolls "
                                    "are counted from 1 in labels")
        columns["bounce"] = np.array([int(m.group(2)) - 1 for m in matches], np.int64)
        columns["roll"] = np.array([int(m.group(1) or 1) - 1 for m in matches], np.int64)
        columns["sigma_s"] = np.array([1e-3 * float(m.group(3) or 0.0) for m in matches])
    return _numbered(path, line_numbers, times, columns)


#: The header row Sonic Visualiser writes above a time-instants layer when its export dialog's
#: "include a header row" is ticked.
_INSTANTS_HEADER = re.compile(r"^\s*time\s*,\s*label\s*$", re.IGNORECASE)


def _is_instants(first: str) -> bool:
    """Whether a first line is a time instant as Sonic Visualiser exports them (``time,label``):
    its header row (:data:`_INSTANTS_HEADER`), or a number, then a comma that cannot be its
    decimal comma."""
    if _INSTANTS_HEADER.match(first):
        return True
    if "," not in first or _DECIMAL_COMMA.match(first):
        return False
    try:
        float(first.split(",", 1)[0])
    except ValueError:
        return False
    return True


def _read_instants(path: Path, lines: list[tuple[int, str]]) -> OnsetTable:
    if _INSTANTS_HEADER.match(lines[0][1]):
        lines = lines[1:]
        if not lines:
            raise DrumrollError(f"{path}: holds no onsets (a header row only)")
    times, names = [], []
    for n, ln in lines:
        time, _, label = ln.partition(",")
        times.append(_number(path, n, time, "time"))
        names.append(label.strip().strip('"'))
    return _labelled(path, [n for n, _ in lines], times, names)


def _instants_text(table: OnsetTable) -> str:
    """The onsets as Sonic Visualiser's time-instants CSV, labelled as the label track is
    (:meth:`~drumroll.onsets.table.OnsetTable.label_names`)."""
    return "".join(f"{t:.9f},{label}\n"
                   for t, label in zip(table.time_s, table.label_names(), strict=True))


def _read_plain(path: Path, lines: list[tuple[int, str]]) -> OnsetTable:
    times = []
    for n, ln in lines:
        if len(ln.split()) != 1:
            raise DrumrollError(f"{path}: line {n}: expected one time per line, found "
                                f"{ln[:40]!r}")
        times.append(_number(path, n, ln, "time"))
    return _numbered(path, [n for n, _ in lines], times, {})


#: The formats, in the order their first lines are tried (plain text last: it takes any).
ONSET_FORMATS: dict[str, OnsetFormat] = {f.name: f for f in (
    OnsetFormat("csv", "drumroll's onset CSV (comma-, semicolon- or tab-separated)", (".csv",),
                lambda first: first.replace(" ", "").lower().startswith("time_s"),
                _read_csv, OnsetTable.to_csv),
    OnsetFormat("labels", "Audacity label track", (".tsv", ".lab", ".labels"),
                lambda first: "\t" in first, _read_labels, OnsetTable.to_labels),
    OnsetFormat("instants", "Sonic Visualiser time instants (time,label; header row or none)",
                (), _is_instants, _read_instants, _instants_text),
    OnsetFormat("text", "one time per line", (".txt",), lambda first: True, _read_plain,
                OnsetTable.to_text),
)}

#: Suffixes read as onset files rather than audio.
ONSET_FILE_SUFFIXES: tuple[str, ...] = tuple(
    suffix for fmt in ONSET_FORMATS.values() for suffix in fmt.suffixes)
