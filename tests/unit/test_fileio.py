"""Outputs written whole or not at all (drumroll.fileio)."""

from __future__ import annotations

import errno
import gc
import os
import pickle
import signal

import pytest

from drumroll import fileio, interruption
from drumroll.errors import DrumrollError


def test_outputs_written_together_are_all_there_or_none(tmp_path):
    first, second = tmp_path / "a.csv", tmp_path / "b.txt"

    def no_room(tmp):
        tmp.write_text("half")
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(fileio.NoSpace) as raised:
        fileio.write_together({first: lambda tmp: tmp.write_text("whole"), second: no_room})
    assert str(raised.value) == (f"{second}: cannot write it: no space left on the device; "
                                 "nothing was written (free some space, or write somewhere "
                                 "else)")
    assert list(tmp_path.iterdir()) == []
    fileio.write_together({first: lambda tmp: tmp.write_text("1"),
                           second: lambda tmp: tmp.write_text("2")})
    assert (first.read_text(), second.read_text()) == ("1", "2")


def test_other_errors_pass_through_and_leave_nothing(tmp_path):
    def broken(tmp):
        raise OSError(errno.EIO, "Input/output error")

    with pytest.raises(OSError, match="Input/output"):
        fileio.write_with(tmp_path / "a.png", broken)
    assert list(tmp_path.iterdir()) == []


def test_no_space_crosses_processes_whole():
    error = fileio.NoSpace("out/corner.png", errno.EFBIG)
    again = pickle.loads(pickle.dumps(error))
    assert type(again) is fileio.NoSpace and str(again) == str(error)
    assert again.errno == errno.EFBIG and isinstance(again, DrumrollError)


def test_no_space_in_staging_is_named_by_the_final_path(tmp_path):
    staging, out = tmp_path / ".staging-x", tmp_path
    error = fileio.NoSpace(staging / "posterior.nc", errno.ENOSPC).moved(staging, out)
    assert error.path == out / "posterior.nc"


class _SignalledWhileCollected:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)  # delivered here: Python drops the exception


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_a_stop_whose_exception_was_lost_still_keeps_nothing(tmp_path):
    """Any output moved into place checks for a stop first (not only estimate's folder)."""
    previous = interruption.install()
    try:
        with pytest.raises(interruption.Terminated):
            with fileio.atomic_path(tmp_path / "a.csv") as tmp:
                tmp.write_text("time_s\n")
                _SignalledWhileCollected()
                gc.collect()
    finally:
        interruption.restore(previous)
    assert list(tmp_path.iterdir()) == []
    fileio.write_text(tmp_path / "a.csv", "time_s\n")
    assert (tmp_path / "a.csv").read_text() == "time_s\n"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes on this system")
def test_a_pipe_or_device_is_never_replaced_even_with_force(tmp_path):
    """An output is renamed onto its name: a FIFO or /dev/null would become a plain file
    (as root, /dev/null itself). Both are refused, --force or not, and left as they are."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for target in (fifo, "/dev/null"):
        with pytest.raises(DrumrollError, match="not a regular file"):
            fileio.check_writable(target, overwrite=True)
    assert fifo.is_fifo()
    assert os.path.exists("/dev/null") and not os.path.isfile("/dev/null")


def test_an_input_is_never_an_output(tmp_path):
    """An output that is one of the command's inputs (its recording, its config) is refused
    even with --force, also through another spelling of its path; other inputs and files
    that do not exist yet are no obstacle."""
    recording = tmp_path / "roll.wav"
    recording.write_bytes(b"RIFF")
    other = tmp_path / "config.toml"
    other.write_text("")
    with pytest.raises(DrumrollError, match="is an input of this command"):
        fileio.check_writable(tmp_path / "." / "roll.wav", overwrite=True,
                              inputs=[other, recording])
    assert recording.read_bytes() == b"RIFF"
    assert fileio.check_writable(other, overwrite=True, inputs=[recording]) == other
    assert fileio.check_writable(tmp_path / "new.csv", inputs=[recording, tmp_path / "gone"])
