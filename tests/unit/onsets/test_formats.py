"""Fuzzing the onset-file reader (issue 14, section 3): whatever a file holds, reading it and
choosing its roll to fit either succeed or raise one :class:`DrumrollError` line, never
another exception.

Files are drawn as people and programs make them: our CSV (any of its columns, in any
order, with a spreadsheet's separator, cells from numbers to words), Audacity labels, one
time per line, and text or bytes of any kind. Deterministic (the ``drumroll`` profile of
tests/conftest.py: derandomize).
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
from hypothesis import event, given, settings
from hypothesis import strategies as st

from drumroll.errors import DrumrollError, DrumrollWarning
from drumroll.onsets import COLUMNS, OnsetTable, read_onsets
from drumroll.pipeline import choose_roll

#: Cells as they come: numbers written every way, the values that break parsers, words.
CELLS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(-10.0, 10.0).map(lambda x: f"{x:.9g}"),
    st.integers(-3, 60).map(str),
    st.integers().map(str),
    st.sampled_from(["", " ", "nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "0x10",
                     "1_000", "1,5", "٣", "１", "abc", "NaN", "+0.5", ".5", "5.", "--1",
                     "1e", "0.1 0.2", '"0.5"', "true", "None", "\x00"]),
    st.text(max_size=6),
)
#: Cells mostly as a roll's file holds them (times, errors, numbers), now and then any.
NUMBERS = st.one_of(st.floats(0.0, 20.0).map(lambda x: f"{x:.6f}"),
                    st.floats(0.0, 20.0).map(repr), st.integers(0, 30).map(str))
MOSTLY_NUMBERS = st.one_of(NUMBERS, NUMBERS, NUMBERS, NUMBERS, NUMBERS, CELLS)
SEPARATORS = st.sampled_from([",", ";", "\t"])


@st.composite
def csv_files(draw) -> str:
    """Our CSV: a header of known and unknown columns (time_s mostly there), rows of cells
    (mostly as many as the header has)."""
    known = draw(st.lists(st.sampled_from(COLUMNS), max_size=len(COLUMNS), unique=True))
    if draw(st.booleans()) and "time_s" not in known:
        known.insert(draw(st.integers(0, len(known))), "time_s")
    header = known + draw(st.lists(st.sampled_from(["x", "Time_s", " time_s", "label", ""]),
                                   max_size=2))
    separator = draw(SEPARATORS)
    rows = []
    for _ in range(draw(st.integers(0, 12))):
        width = len(header) if draw(st.integers(0, 9)) else draw(st.integers(0, 9))
        rows.append(separator.join(draw(MOSTLY_NUMBERS) for _ in range(width)))
    return "\n".join([separator.join(header), *rows]) + draw(st.sampled_from(["", "\n"]))


@st.composite
def plausible_csv_files(draw) -> str:
    """Our CSV with numbers that could be a roll: times (sorted or not, repeated, negative),
    sigma_s, bounce and roll numbers (in order or not)."""
    n = draw(st.integers(0, 14))
    flights = draw(st.lists(st.floats(1e-9, 2.0), min_size=n, max_size=n))
    times = [float(t) for t in 0.3 + np.cumsum(flights)] if n else []
    mistake = draw(st.sampled_from(["none", "none", "none", "none", "repeat", "negate",
                                    "huge", "units", "shuffle", "reverse", "sigma"]))
    if times and mistake != "none":
        i = draw(st.integers(0, n - 1))
        if mistake == "repeat":
            times.insert(i, times[i])
        elif mistake == "negate":
            times[i] = -times[i]
        elif mistake == "huge":
            times[i] = 1e308
        elif mistake == "units":  # microseconds, not seconds
            times = [t * 1e6 for t in times]
        elif mistake == "sigma":
            pass  # below
        elif mistake == "shuffle":
            times = draw(st.permutations(times))
        else:
            times = times[::-1]
    n = len(times)
    sigma = draw(st.lists(st.sampled_from(["0", "1e-4", "2e-5", "3.5e-3"]), min_size=n,
                          max_size=n))
    if mistake == "sigma" and n:
        sigma[draw(st.integers(0, n - 1))] = draw(st.sampled_from(["-1e-3", "nan", "inf",
                                                                   "1e300"]))
    bounce = draw(st.one_of(st.just(list(range(n))), st.just(list(range(n))),
                            st.lists(st.integers(0, 20), min_size=n, max_size=n,
                                     unique=True).map(sorted),
                            st.lists(st.integers(-1, 20), min_size=n, max_size=n)))
    roll = draw(st.one_of(st.just([0] * n), st.just([0] * n),
                          st.lists(st.integers(0, 3), min_size=n, max_size=n).map(sorted)))
    rows = [f"{t!r},{s},{b},{r}" for t, s, b, r in zip(times, sigma, bounce, roll,
                                                          strict=True)]
    return "\n".join(["time_s,sigma_s,bounce,roll", *rows]) + "\n"


@st.composite
def label_files(draw) -> str:
    """Audacity labels: start, end and a name (``hit n``, ``roll m hit n`` or anything)."""
    names = st.one_of(st.integers(-1, 30).map(lambda n: f"hit {n}"),
                      st.tuples(st.integers(-1, 4), st.integers(-1, 30)).map(
                          lambda mn: f"roll {mn[0]} hit {mn[1]}"),
                      st.text(max_size=8))
    lines = []
    for _ in range(draw(st.integers(1, 12))):
        start = draw(MOSTLY_NUMBERS)
        parts = [start, draw(st.one_of(st.just(start), MOSTLY_NUMBERS))]
        if draw(st.integers(0, 4)):
            parts.append(draw(names))
        lines.append("\t".join(parts))
        if not draw(st.integers(0, 6)):
            lines.append("\\\t0\t0")  # a spectral selection's continuation line
    return "\n".join(lines) + "\n"


@st.composite
def plain_files(draw) -> str:
    """One time per line, with comments and blank lines among them."""
    lines = draw(st.lists(st.one_of(MOSTLY_NUMBERS, st.just("# a comment"), st.just("")),
                          max_size=14))
    return "\n".join(lines)


TEXTS = st.one_of(csv_files(), plausible_csv_files(), plausible_csv_files(), label_files(),
                  plain_files(), st.text(max_size=200))
#: What a user may name an onset file.
SUFFIXES = st.sampled_from([".csv", ".txt", ".tsv", ".lab", ".labels"])


def read_and_choose(content: str | bytes, suffix: str) -> OnsetTable | None:
    """Read ``content`` as an onset file and choose its roll, as ``estimate`` does first;
    None when refused in one line."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"onsets{suffix}"
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8", errors="surrogatepass")
        try:
            with warnings.catch_warnings(record=True) as said:
                warnings.simplefilter("always", DrumrollWarning)
                table = read_onsets(path)
                choose_roll(table, None, str(path))
        except DrumrollError as exc:
            event("refused in one line")
            message = str(exc)
            assert message and "\n" not in message.strip(), message
            return None
        for warning in said:  # what is read with a remark is remarked on in a line too
            event("read with a warning")
            assert "\n" not in str(warning.message).strip(), warning.message
    event("read")  # --hypothesis-show-statistics gives the shares
    return table


@settings(max_examples=300)
@given(TEXTS, SUFFIXES)
def test_any_text_is_read_or_refused_in_one_line(content, suffix):
    table = read_and_choose(content, suffix)
    if table is not None:  # what is read is what a fit may be given
        assert np.all(np.isfinite(table.time_s)) and np.all(table.time_s >= 0)
        assert np.all(np.diff(table.time_s) > 0)
        sigma = np.asarray(table.sigma_s, float)
        assert np.all(np.isfinite(sigma)) and np.all(sigma >= 0)


@settings(max_examples=100)
@given(st.binary(max_size=300), SUFFIXES)
def test_any_bytes_are_read_or_refused_in_one_line(content, suffix):
    read_and_choose(content, suffix)


@settings(max_examples=100)
@given(st.data())
def test_a_written_table_reads_back_the_same(data):
    """What we write, we read: each format's writer against the reader."""
    n = data.draw(st.integers(1, 12))
    times = np.cumsum(data.draw(st.lists(st.floats(1e-4, 2.0), min_size=n, max_size=n)))
    table = OnsetTable(times, np.full(n, 0.5), np.full(n, 20.0), np.full(n, 1e-4))
    for suffix, text in ((".csv", table.to_csv()), (".txt", table.to_text()),
                         (".lab", table.to_labels())):
        again = read_and_choose(text, suffix)
        assert again is not None, suffix
        np.testing.assert_allclose(again.time_s, table.time_s, rtol=1e-6, atol=1e-6)
        np.testing.assert_array_equal(again.bounce, table.bounce)
