"""A disk with no room for the outputs (issue 14, item 5): one line naming the output and
why, exit 2, nothing written, no staging left, no crash.

Two real mechanisms. A file size limit (``ulimit -f``, RLIMIT_FSIZE, set in the command's
process before it starts) works on any POSIX machine: a write beyond it fails with EFBIG,
as a write to a full disk fails with ENOSPC. A small tmpfs is the full disk itself; mounting
one needs root in a container that allows it, so those tests skip elsewhere.
"""

from __future__ import annotations

import contextlib
import subprocess
import sys
import uuid
from pathlib import Path

import numpy as np
import pytest

from configs import BALL_CONFIG
from paths import DATA

resource = pytest.importorskip("resource")  # POSIX only

#: The file size limit of the tests: an onset CSV, its labels or a truth file fits (a few
#: KB), a figure, a recording or a posterior does not (50 KB and more).
LIMIT = 20_000


def drumroll(*arguments: str | Path, limit: int | None = LIMIT, cwd: Path | None = None
             ) -> subprocess.CompletedProcess:
    """Run ``drumroll`` as a user would, with files limited to ``limit`` bytes."""
    def limited() -> None:
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return subprocess.run([sys.executable, "-m", "drumroll", *map(str, arguments)],
                          preexec_fn=limited, capture_output=True, text=True, timeout=300,
                          cwd=cwd, check=False)


def one_line(proc: subprocess.CompletedProcess) -> str:
    """The command's only stderr line, after checking it failed as the user's problem."""
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    return lines[0]


def everything_in(folder: Path) -> list[str]:
    """Every file and folder under ``folder`` (hidden ones too), relative to it."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.fixture
def ball(tmp_path):
    """A bouncing ball's onset file and config (a quick fit: one model, no evidence)."""
    config = tmp_path / "ball.toml"
    config.write_text(BALL_CONFIG)
    flights = 0.6 * 0.7 ** np.arange(1, 12)
    times = 0.3 + np.concatenate([[0.0], np.cumsum(flights)])
    onsets = tmp_path / "ball.txt"
    onsets.write_text("\n".join(f"{t:.7f}" for t in times) + "\n")
    return onsets, config


def test_estimate_beyond_the_file_size_limit_writes_nothing(tmp_path, ball):
    onsets, config = ball
    out = tmp_path / "out"
    line = one_line(drumroll("estimate", onsets, "--prior", config, "-o", out, "-q"))
    assert line == (f"drumroll: error: {out}/posterior.nc: cannot write it: the file would "
                    "exceed the file size limit (ulimit -f, or the file system's); nothing "
                    "was written (raise the limit, or write somewhere else)")
    assert not out.exists()  # no results, no .staging-*


def test_onsets_with_labels_and_plot_are_written_all_or_none(tmp_path):
    """The CSV and the labels fit, the figure does not: none of the three is left (the CSV
    and the labels were)."""
    outputs = [tmp_path / name for name in ("o.csv", "o.txt", "o.png")]
    line = one_line(drumroll("onsets", DATA / "table2_h80.flac", "-o", outputs[0], "--labels",
                             outputs[1], "--plot", outputs[2]))
    assert line.startswith(f"drumroll: error: {outputs[2]}: cannot write it: the file would "
                           "exceed the file size limit")
    assert everything_in(tmp_path) == []


def test_simulate_writes_the_recording_and_its_truth_together_or_neither(tmp_path):
    recording = tmp_path / "roll.wav"
    line = one_line(drumroll("simulate", DATA / "table1_d110.toml", "-o", recording))
    assert line.startswith(f"drumroll: error: {recording}: cannot write it: the file would "
                           "exceed the file size limit")
    assert everything_in(tmp_path) == []


def test_table_and_figure_are_written_together_or_neither(tmp_path, ball):
    onsets, config = ball
    runs = tmp_path / "runs.toml"
    runs.write_text(f'base = "{config.name}"\n'
                    f'[[run]]\nlabel = "a"\nsource = "{onsets.name}"\n')
    table, figure = tmp_path / "t.md", tmp_path / "t.png"
    page = tmp_path / "t.html"  # the table's HTML page, the figure embedded: the largest
    line = one_line(drumroll("table", runs, "-o", table, "--plot", figure, "-q",
                             "--no-cache"))
    assert line.startswith(f"drumroll: error: {page}: cannot write it: the file would exceed")
    assert not table.exists() and not figure.exists() and not page.exists()


@pytest.fixture
def full_disk(tmp_path):
    """``mount(size)``: a mounted tmpfs of ``size`` ("200k": the issue's), or a skip where
    none can be mounted."""
    mounted: list[Path] = []

    def mount(size: str) -> Path:
        folder = tmp_path / f"tmpfs-{uuid.uuid4().hex[:8]}"
        folder.mkdir()
        try:
            proc = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs",
                                   str(folder)], capture_output=True, timeout=30, check=False)
        except (OSError, subprocess.TimeoutExpired):
            proc = None
        if proc is None or proc.returncode != 0:
            pytest.skip("cannot mount a tmpfs here (needs root, in a container that allows "
                        "it)")
        mounted.append(folder)
        return folder

    yield mount
    for folder in mounted:
        with contextlib.suppress(OSError, subprocess.TimeoutExpired):
            subprocess.run(["umount", str(folder)], capture_output=True, timeout=30,
                           check=False)


def test_estimate_on_a_full_disk_is_one_line_and_no_crash(full_disk, ball):
    # It was an HDF5 traceback writing posterior.nc, then a segmentation fault (exit 139),
    # and a .staging-* folder with the half-written file left behind.
    onsets, config = ball
    disk = full_disk("200k")
    for _ in range(2):  # the second run failed too, leaving a second staging folder
        line = one_line(drumroll("estimate", onsets, "--prior", config, "-o", disk / "out",
                                 "-q", limit=None))
        assert line == (f"drumroll: error: {disk}/out/posterior.nc: cannot write it: no space "
                        "left on the device; nothing was written (free some space, or write "
                        "somewhere else)")
        assert everything_in(disk) == []


def test_onsets_on_a_full_disk_leave_no_csv_or_labels(full_disk):
    disk = full_disk("40k")  # room for the CSV and the labels, not the figure
    outputs = [disk / name for name in ("o.csv", "o.txt", "o.png")]
    line = one_line(drumroll("onsets", DATA / "table2_h80.flac", "-o", outputs[0], "--labels",
                             outputs[1], "--plot", outputs[2], limit=None))
    assert line.startswith(f"drumroll: error: {outputs[2]}: cannot write it: no space left")
    assert everything_in(disk) == []


def test_a_table_cache_on_a_full_disk_is_a_warning_not_a_lost_table(full_disk, ball, tmp_path):
    """The cache is an aid: the table computed is printed, the cache's failure said once."""
    onsets, config = ball
    disk = full_disk("16k")
    with contextlib.suppress(OSError):  # fill the disk to the last byte
        with open(disk / "filler", "wb") as filler:
            while True:
                filler.write(b"\0" * 4096)
                filler.flush()
    runs = tmp_path / "runs.toml"
    runs.write_text(f'base = "{config.name}"\n'
                    f'[[run]]\nlabel = "a"\nsource = "{onsets.name}"\n'
                    f'[[run]]\nlabel = "b"\nsource = "{onsets.name}"\n')
    proc = drumroll("table", runs, "--cache-dir", disk / "cache", "-q", limit=None)
    assert proc.returncode == 0, proc.stderr
    assert "| a |" in proc.stdout and "| b |" in proc.stdout
    assert proc.stderr.strip().splitlines() == [
        f"drumroll: warning: {disk}/cache: the cache is not written (no space left on "
        "the device); the next run computes these runs again"]
