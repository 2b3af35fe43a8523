"""What C code writes to file descriptor 2 while a decoder runs: dropped, worded or passed
on (drumroll.audio.chatter)."""

from __future__ import annotations

import os
import warnings

import pytest

from drumroll.audio.chatter import quiet
from drumroll.errors import DrumrollWarning


def c_write(text: str) -> None:
    """Write to descriptor 2 as C code does (past Python's sys.stderr)."""
    os.write(2, text.encode())


def test_seeking_chatter_is_dropped(capfd):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with quiet("a.mp3"):
            c_write("Warning: Xing stream size off by more than 1%, fuzzy seeking may be even "
                    "more fuzzy than by design!\n")
    assert capfd.readouterr().err == ""


def test_damaged_frames_are_one_warning_naming_the_file(capfd):
    with pytest.warns(DrumrollWarning) as said:
        with quiet("a.mp3"):
            c_write("Note: Illegal Audio-MPEG-Header 0xfff060c4 at offset 4848.\n"
                    "Note: Trying to resync...\nNote: Skipped 469 bytes in input.\n"
                    "[src/libmpg123/layer3.c:INT123_do_layer3():1804] error: dequantization "
                    "failed!\n")
    assert [str(w.message) for w in said] == [
        "a.mp3: the MP3 decoder met damaged data and skipped over it; an impact there may be "
        "lost"]
    assert capfd.readouterr().err == ""


def test_anything_else_is_passed_on_even_when_the_call_fails(capfd):
    with pytest.raises(ValueError), quiet("a.mp3"):
        c_write("libfoo: the disk is on fire\n")
        raise ValueError
    assert capfd.readouterr().err == "libfoo: the disk is on fire\n"


def test_descriptor_2_is_restored():
    before = os.fstat(2)
    with quiet("a.mp3"):
        assert os.fstat(2).st_ino != before.st_ino
    after = os.fstat(2)
    assert (after.st_dev, after.st_ino) == (before.st_dev, before.st_ino)
