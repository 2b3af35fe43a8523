"""The onset table's contract: bounce and roll numbers, their files, rolls and gaps."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from drumroll.errors import DrumrollError, DrumrollWarning
from drumroll.onsets import COLUMNS, ONSET_FILE_SUFFIXES, ONSET_FORMATS, OnsetTable, read_onsets

OLD_HEADER = "time_s,amplitude,snr_db,sigma_s,interval_s"


def two_rolls() -> OnsetTable:
    """Roll 0: bounces 0, 1, 3 (2 not heard); roll 1: bounces 0, 1, 2, 3. Given unsorted."""
    times = np.array([2.3, 0.5, 2.0, 0.91, 0.72, 2.5, 2.62])
    order = np.array([4, 0, 3, 2, 1, 5, 6])  # the rows' places in time order
    amplitude = np.linspace(0.9, 0.3, 7)[order]
    sigma = np.linspace(1e-5, 7e-5, 7)[order]
    return OnsetTable(times, amplitude, np.full(7, 20.0), sigma,
                      bounce=np.array([1, 0, 0, 3, 1, 2, 3]), roll=np.array([1, 0, 1, 0, 0, 1, 1]))


def test_header_appends_the_numbers_to_the_old_columns():
    assert ",".join(COLUMNS) == OLD_HEADER + ",bounce,roll"


def test_numbers_follow_the_sort_by_time():
    table = two_rolls()
    np.testing.assert_array_equal(table.time_s, [0.5, 0.72, 0.91, 2.0, 2.3, 2.5, 2.62])
    np.testing.assert_array_equal(table.bounce, [0, 1, 3, 0, 1, 2, 3])
    np.testing.assert_array_equal(table.roll, [0, 0, 0, 1, 1, 1, 1])
    np.testing.assert_allclose(table.amplitude, np.linspace(0.9, 0.3, 7))
    # the interval is since the previous onset of the same roll: NaN at each roll's start
    np.testing.assert_allclose(table.interval_s, [np.nan, 0.22, 0.19, np.nan, 0.3, 0.2, 0.12],
                               equal_nan=True)


def test_defaults_number_each_roll_from_zero():
    times = np.array([3.0, 1.0, 2.0, 5.0, 4.0])
    table = OnsetTable(times, times, times, 0 * times)
    np.testing.assert_array_equal(table.bounce, [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(table.roll, [0] * 5)
    assert table.rolls == (0,) and table.gaps() == []
    table = OnsetTable(times, times, times, 0 * times, roll=[1, 0, 0, 1, 1])
    np.testing.assert_array_equal(table.bounce, [0, 1, 0, 1, 2])


def test_rolls_selection_gaps_and_longest():
    table = two_rolls()
    assert table.rolls == (0, 1) and table.roll_sizes() == {0: 3, 1: 4}
    assert table.longest_roll == 1
    assert table.gaps(0) == [2] and table.gaps(1) == []
    with pytest.raises(ValueError, match="say which"):
        table.gaps()
    first = table.select_roll(0)
    np.testing.assert_array_equal(first.bounce, [0, 1, 3])
    assert first.rolls == (0,) and first.gaps() == [2]
    np.testing.assert_allclose(first.interval_s, [np.nan, 0.22, 0.19], equal_nan=True)
    with pytest.raises(DrumrollError, match="no roll 2; the onsets hold rolls 0, 1"):
        table.select_roll(2)
    # a tie goes to the earlier roll
    tie = OnsetTable(np.arange(4.0), np.zeros(4), np.zeros(4), np.zeros(4), roll=[0, 0, 3, 3])
    assert tie.longest_roll == 0 and tie.rolls == (0, 3)


@pytest.mark.parametrize(("bounce", "roll", "message"), [
    ([0, 2, 1], None, "bounce 1 after bounce 2 of roll 0"),
    ([0, -1, 2], None, "bounce -1 is negative"),
    ([0, 1.5, 2], None, "whole numbers"),
    (None, [1, 0, 0], "roll 0 after roll 1"),
    ([0, 1], None, "bounce has 2 values for 3 onsets"),
])
def test_constructor_rejects_bad_numbers(bounce, roll, message):
    with pytest.raises(ValueError, match=message):
        OnsetTable(np.arange(3.0), np.zeros(3), np.zeros(3), np.zeros(3), bounce=bounce,
                   roll=roll)


def test_csv_round_trip_with_bounce_and_roll(tmp_path):
    table = two_rolls()
    path = tmp_path / "o.csv"
    path.write_text(table.to_csv())
    lines = path.read_text().splitlines()
    assert lines[0] == ",".join(COLUMNS)
    assert lines[3].endswith(",3,0") and lines[4].split(",")[-3:] == ["nan", "0", "1"]
    back = read_onsets(path)
    for name in ("time_s", "amplitude", "sigma_s", "interval_s"):
        np.testing.assert_allclose(getattr(back, name), getattr(table, name), equal_nan=True)
    np.testing.assert_array_equal(back.bounce, table.bounce)
    np.testing.assert_array_equal(back.roll, table.roll)
    assert back.bounce.dtype.kind == "i" and back.roll.dtype.kind == "i"


def test_old_csv_without_numbers_still_reads(tmp_path):
    path = tmp_path / "old.csv"
    path.write_text(OLD_HEADER + "\n0.91,0.1,20,1e-05,0.19\n0.5,0.3,30,1e-05,nan\n"
                    "0.72,0.2,25,2e-05,0.22\n")
    with pytest.warns(DrumrollWarning, match="line 3: onset 0.5 s comes before"):
        table = read_onsets(path)
    np.testing.assert_allclose(table.time_s, [0.5, 0.72, 0.91])
    np.testing.assert_array_equal(table.bounce, [0, 1, 2])
    np.testing.assert_array_equal(table.roll, [0, 0, 0])
    only_rolls = tmp_path / "rolls.csv"
    only_rolls.write_text("time_s,roll\n0.5,0\n0.7,0\n2.0,1\n2.2,1\n2.3,1\n")
    np.testing.assert_array_equal(read_onsets(only_rolls).bounce, [0, 1, 0, 1, 2])


@pytest.mark.parametrize("separator", [";", "\t"])
def test_a_spreadsheets_csv_reads_whatever_its_separator(tmp_path, separator):
    # A spreadsheet set to a language with decimal commas exports ';'-separated CSV; it was
    # refused with "header lacks column time_s" although its header has it.
    path = tmp_path / "sheet.csv"
    path.write_text(separator.join(["time_s", "sigma_s", "bounce"]) + "\n"
                    + "\n".join(separator.join(row) for row in
                                (["0.5", "0.0001", "0"], ["0.7", "0.0002", "1"],
                                 ["1.04", "0.0001", "3"])) + "\n")
    table = read_onsets(path)
    np.testing.assert_allclose(table.time_s, [0.5, 0.7, 1.04])
    np.testing.assert_allclose(table.sigma_s, [1e-4, 2e-4, 1e-4])
    np.testing.assert_array_equal(table.bounce, [0, 1, 3])
    path.write_text("time_s;sigma_s\n0.5;0.0001;7\n")
    with pytest.raises(DrumrollError, match="line 2: expected 2 semicolon-separated values"):
        read_onsets(path)


@pytest.mark.parametrize(("name", "text"), [
    ("sheet.csv", "time_s;sigma_s\r\n0,5;0,0001\r\n0,72;0,0002\r\n1,04;1e-4\r\n"),
    ("sheet.csv", "time_s\tsigma_s\n0,5\t0,0001\n0,72\t0,0002\n1,04\t0,0001\n"),
    ("column.csv", "time_s\n0,5\n0,72\n1,04\n"),
    ("plain.txt", "0,5\n0,72\n1,04\n"),
])
def test_decimal_commas_are_read_where_a_comma_cannot_separate(tmp_path, name, text):
    """A spreadsheet in a language with decimal commas writes 0,5 with ';' between columns
    (and Windows line ends): refused as "time_s '0,5' is not a number". A comma between
    digits where it cannot be a separator is a decimal comma."""
    path = tmp_path / name
    path.write_bytes(text.encode())
    table = read_onsets(path)
    np.testing.assert_allclose(table.time_s, [0.5, 0.72, 1.04])
    if "sigma_s" in text:
        np.testing.assert_allclose(table.sigma_s, [1e-4, 2e-4, 1e-4])


def test_a_comma_that_may_separate_is_never_read_as_decimal(tmp_path):
    """In a comma-separated CSV a row '0,5,0,0001' has four values, not two: refused."""
    path = tmp_path / "ambiguous.csv"
    path.write_text("time_s,sigma_s\n0,5,0,0001\n")
    with pytest.raises(DrumrollError, match="line 2: expected 2 comma-separated values"):
        read_onsets(path)


@pytest.mark.parametrize(("text", "where", "what"), [
    ("time_s,bounce\n0.1,0\n0.2,1.5\n", "line 3", "bounce '1.5' is not a whole number"),
    ("time_s,bounce\n0.1,0\n0.2,two\n", "line 3", "bounce 'two' is not a number"),
    ("time_s,bounce\n0.1,0\n0.2,nan\n", "line 3", "bounce 'nan' is not a whole number"),
    ("time_s,bounce\n0.1,0\n0.2,-1\n", "line 3", "bounce -1 is negative"),
    ("time_s,bounce\n0.1,1\n0.2,0\n", "line 3",
     "bounce 0 after bounce 1 of roll 0: bounce numbers must increase with time within a roll"),
    ("time_s,bounce\n0.1,0\n0.2,3\n0.3,3\n", "line 4", "bounce 3 after bounce 3"),
    ("time_s,bounce,roll\n0.1,0,1\n0.2,1,0\n", "line 3",
     "roll 0 after roll 1: rolls are numbered in time order"),
    ("time_s,roll\n0.1,0\n0.2,0.5\n", "line 3", "roll '0.5' is not a whole number"),
])
def test_bad_bounce_columns_are_one_line_naming_it(tmp_path, text, where, what):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(DrumrollError) as caught:
        read_onsets(path)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {where}: ") and what in message


def test_audacity_labels_carry_the_numbers(tmp_path):
    table = two_rolls()
    labels = table.to_labels().splitlines()
    assert labels[2].endswith("\troll 1 hit 4, sd 0.0300 ms")
    assert labels[3].endswith("\troll 2 hit 1, sd 0.0400 ms")
    path = tmp_path / "labels.txt"
    path.write_text(table.to_labels())
    back = read_onsets(path)
    np.testing.assert_array_equal(back.bounce, table.bounce)
    np.testing.assert_array_equal(back.roll, table.roll)
    np.testing.assert_allclose(back.sigma_s, table.sigma_s, atol=1e-10)
    # one roll: the labels written before bounce numbers existed (hit 1 is bounce 0)
    one = table.select_roll(1)
    assert one.to_labels().splitlines()[0].endswith("\troll 2 hit 1, sd 0.0400 ms")
    plain = OnsetTable(one.time_s, one.amplitude, one.snr_db, np.zeros(4))
    assert [ln.split("\t")[2] for ln in plain.to_labels().splitlines()] == [
        "hit 1", "hit 2", "hit 3", "hit 4"]
    path.write_text("0.5\t0.5\thit 1\n0.72\t0.72\tHit 2\n0.91\t0.91\thit 4\n")
    np.testing.assert_array_equal(read_onsets(path).bounce, [0, 1, 3])
    # a label's ", sd x ms" is its onset's timing error; one added by hand has none
    path.write_text("0.5\t0.5\thit 1, sd 0.12 ms\n0.72\t0.72\thit 2\n"
                    "0.91\t0.91\troll 1 hit 4 SD 1.5e-1 ms\n")
    np.testing.assert_allclose(read_onsets(path).sigma_s, [1.2e-4, 0.0, 1.5e-4])
    np.testing.assert_array_equal(read_onsets(path).bounce, [0, 1, 3])
    # labels named otherwise are numbered in time order, as before
    path.write_text("0.5\t0.5\thit 1\n0.72\t0.72\tthe faint one\n0.91\t0.91\thit 4\n")
    np.testing.assert_array_equal(read_onsets(path).bounce, [0, 1, 2])
    path.write_text("0.5\t0.5\thit 1\n0.72\t0.72\thit 0\n")
    with pytest.raises(DrumrollError, match="line 2: label 'hit 0': hits and rolls are "
                                            "counted from 1"):
        read_onsets(path)
    path.write_text("0.5\t0.5\thit 2\n0.72\t0.72\thit 1\n")
    with pytest.raises(DrumrollError, match="line 2: bounce 0 after bounce 1"):
        read_onsets(path)


def test_plain_text_is_one_roll_numbered_in_order(tmp_path):
    path = tmp_path / "plain.txt"
    path.write_text(two_rolls().to_text())
    table = read_onsets(path)
    np.testing.assert_array_equal(table.bounce, np.arange(7))
    assert table.rolls == (0,)


@pytest.mark.parametrize("fmt", list(ONSET_FORMATS.values()), ids=list(ONSET_FORMATS))
def test_every_onset_format_reads_back_what_it_writes(fmt, tmp_path):
    """Written in a format and read back (recognised by content, whatever the suffix), the
    onsets keep their times, and their numbers where the format carries them."""
    carries_numbers = fmt.name != "text"
    times = np.array([0.5, 0.72, 0.88, 1.0])
    table = two_rolls() if carries_numbers else OnsetTable(times, np.ones(4), np.ones(4),
                                                           np.zeros(4))
    # A format with no suffix of its own (Sonic Visualiser's instants) is exported as .csv.
    for suffix in fmt.suffixes or (".csv",):
        assert suffix in ONSET_FILE_SUFFIXES
        path = tmp_path / f"onsets{suffix}"
        path.write_text(fmt.write(table))
        again = read_onsets(path)
        np.testing.assert_allclose(again.time_s, table.time_s, atol=1e-6)
        np.testing.assert_array_equal(again.bounce, table.bounce)
        np.testing.assert_array_equal(again.roll, table.roll)
        first = next(line for line in path.read_text().splitlines() if line)
        assert next(f.name for f in ONSET_FORMATS.values() if f.recognises(first)) == fmt.name


def test_sonic_visualisers_time_instants_are_read(tmp_path):
    """Sonic Visualiser exports a time-instants layer as ``time,label`` lines, with a header
    row ``TIME,LABEL`` or without (a .csv): refused as "time '0.5,New Point' is not a
    number". The first field is the time;
    labels ``hit n`` carry the numbers as Audacity's do, others leave them to time order;
    written back, the numbers and timing errors survive."""
    path = tmp_path / "instants.csv"
    path.write_text("0.500000000,New Point\n0.720000000,New Point\n0.910000000,\n")
    table = read_onsets(path)
    np.testing.assert_allclose(table.time_s, [0.5, 0.72, 0.91])
    np.testing.assert_array_equal(table.bounce, [0, 1, 2])
    path.write_text('0.5,"hit 1"\n0.72,hit 2\n0.91,hit 4, sd 0.2 ms\n')
    table = read_onsets(path)
    np.testing.assert_array_equal(table.bounce, [0, 1, 3])
    np.testing.assert_allclose(table.sigma_s, [0.0, 0.0, 2e-4])
    rolls = two_rolls()
    path.write_text(ONSET_FORMATS["instants"].write(rolls))
    back = read_onsets(path)
    np.testing.assert_allclose(back.time_s, rolls.time_s, atol=1e-9)
    np.testing.assert_array_equal(back.bounce, rolls.bounce)
    np.testing.assert_array_equal(back.roll, rolls.roll)
    np.testing.assert_allclose(back.sigma_s, rolls.sigma_s, atol=1e-10)
    # a decimal comma alone on a line is still one time, not a time and a label
    path.write_text("0,5\n0,72\n")
    np.testing.assert_allclose(read_onsets(path).time_s, [0.5, 0.72])
    # the export dialog's header row ("include a header row"), in either case
    for header in ("TIME,LABEL", "time,label"):
        path.write_text(f"{header}\n0.5,hit 1\n0.72,hit 2\n0.91,New Point\n")
        table = read_onsets(path)
        np.testing.assert_allclose(table.time_s, [0.5, 0.72, 0.91])
        np.testing.assert_array_equal(table.bounce, [0, 1, 2])
    path.write_text("TIME,LABEL\n")
    with pytest.raises(DrumrollError, match="holds no onsets"):
        read_onsets(path)


def test_onsets_out_of_time_order_are_read_sorted_with_a_warning(tmp_path):
    """A hand-made list with a line out of order (two lists pasted together, a typo) was
    sorted without a word; it is still read in time order, and the first line that goes
    back in time is named."""
    path = tmp_path / "hand.txt"
    path.write_text("0.30\n0.10\n0.48\n0.65\n")
    with pytest.warns(DrumrollWarning, match=r"hand.txt: line 2: onset 0.1 s comes before "
                      r"the line above it \(0.3 s\)"):
        table = read_onsets(path)
    np.testing.assert_allclose(table.time_s, [0.1, 0.3, 0.48, 0.65])
    path.write_text("0.10\n0.30\n0.48\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_onsets(path)
