"""What the libraries say never reaches the user raw (issue 14, item 9): each message is one
drumroll line in the user's words, or nothing where it tells the user nothing.

Run as a user runs the commands, in a process of their own: the warnings are printed by the
command line's own printer (pytest would record them), and libmpg123 writes to the process's
file descriptor 2 itself.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from configs import BALL_CONFIG
from paths import DATA

#: Words of the libraries' own messages, none of which may reach the user.
RAW = ("encountered in", "Glyph", "missing from font", "Xing stream", "Note:", "libmpg123",
       "Traceback", "RuntimeWarning", "UserWarning")


def drumroll(*arguments: str | Path) -> subprocess.CompletedProcess:
    """Run ``drumroll`` as a user would."""
    return subprocess.run([sys.executable, "-m", "drumroll", *map(str, arguments)],
                          capture_output=True, text=True, timeout=300, check=False)


def stderr_lines(proc: subprocess.CompletedProcess) -> list[str]:
    """The command's stderr lines, after checking none is a library's."""
    for word in RAW:
        assert word not in proc.stderr, proc.stderr
    return proc.stderr.strip().splitlines()


@pytest.fixture
def huge_t_b(tmp_path):
    """A ball's config whose t_b prior reaches 1e308 s (numpy overflows on its draws)."""
    config = tmp_path / "huge.toml"
    config.write_text(BALL_CONFIG.replace("high = 3.0", "high = 1e308"))
    return config


def test_no_overflow_warning_before_the_error(tmp_path, huge_t_b):
    # "drumroll: warning: overflow encountered in accumulate" came first.
    times = 0.3 + np.concatenate([[0.0], np.cumsum(0.6 * 0.7 ** np.arange(1, 12))])
    onsets = tmp_path / "ball.txt"
    onsets.write_text("\n".join(f"{t:.7f}" for t in times) + "\n")
    proc = drumroll("estimate", onsets, "--prior", huge_t_b, "-o", tmp_path / "out", "-q")
    assert proc.returncode == 2
    [line] = stderr_lines(proc)
    assert line.startswith("drumroll: error: powerlaw: no parameter value drawn from the priors")


def test_a_prediction_that_overflows_says_so_in_words(huge_t_b):
    # Two raw "overflow encountered in reduce" lines, then a table of "inf s".
    proc = drumroll("predict", huge_t_b)
    assert proc.returncode == 0
    assert stderr_lines(proc) == [
        "drumroll: warning: powerlaw: t_B, T_1, T_2, T_3, T_4, T_5: the draws are too large "
        "to average (the mean or sd overflows); check the priors' ranges and units"]


def test_characters_the_font_lacks_are_one_warning(tmp_path):
    # One matplotlib warning per character ("Glyph 40723 (\N{CJK UNIFIED IDEOGRAPH-9F13})
    # missing from font(s) DejaVu Sans."), in the figure of a recording named in Chinese.
    recording = tmp_path / "鼓🥁.wav"
    shutil.copy(DATA / "pingpong.wav", recording)
    figure = tmp_path / "onsets.png"
    proc = drumroll("onsets", recording, "--plot", figure)
    assert proc.returncode == 0 and figure.exists()
    assert stderr_lines(proc) == [
        "drumroll: warning: onsets.png: the figure's font cannot draw 鼓🥁 (from a file name "
        "or label); they show as empty boxes"]


@pytest.fixture(scope="module")
def mp3(tmp_path_factory):
    """The bundled h = 80 mm roll as an MP3 (libsndfile's encoder, where it has one)."""
    if "MP3" not in sf.available_formats():
        pytest.skip("this libsndfile writes no MP3")
    samples, rate = sf.read(DATA / "table2_h80.flac")
    path = tmp_path_factory.mktemp("mp3") / "roll.mp3"
    sf.write(path, samples, rate, format="MP3", subtype="MPEG_LAYER_III")
    return path


def test_a_truncated_mp3_is_said_once_in_words(tmp_path, mp3):
    # libmpg123 wrote "Warning: Xing stream size off by more than 1%, fuzzy seeking may be
    # even more fuzzy than by design!" at each of the file's five openings.
    cut = tmp_path / "cut.mp3"
    data = mp3.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    proc = drumroll("onsets", cut)
    assert proc.returncode == 0
    lines = stderr_lines(proc)
    declared = sf.info(DATA / "table2_h80.flac").duration  # the whole roll the MP3 holds
    assert lines[0].startswith(f"drumroll: warning: {cut}: the file is cut short: its header "
                               f"declares {declared:.2f} s of audio")
    assert all(line.startswith("drumroll: ") for line in lines)
    # The bit rate is what the half holds over the half's length (it was over the whole
    # roll's, half the whole file's: 39 kb/s against 77, and the timing floor of that rate).
    whole = stderr_lines(drumroll("onsets", mp3))
    rate = {name: float(re.search(r"MP3 at (\d+) kb/s", " ".join(said)).group(1))
            for name, said in (("whole", whole), ("half", lines))}
    assert abs(rate["half"] - rate["whole"]) < 0.2 * rate["whole"], rate


def test_damaged_mp3_frames_are_one_warning(tmp_path, mp3):
    # Dozens of "Note: Illegal Audio-MPEG-Header …", "Note: Trying to resync..." and
    # "[src/libmpg123/layer3.c:…] error: …" lines.
    damaged = tmp_path / "damaged.mp3"
    data = bytearray(mp3.read_bytes())
    # bytes changed at random past the header (a draw whose damage the decoder meets and
    # reports: which bytes it notices depends on the recording's frames)
    rng = np.random.default_rng(2)
    for at in rng.integers(2000, len(data), 200):
        data[at] = int(rng.integers(256))
    damaged.write_bytes(bytes(data))
    proc = drumroll("onsets", damaged)
    lines = stderr_lines(proc)
    said = (f"drumroll: warning: {damaged}: the MP3 decoder met damaged data and skipped over "
            "it; an impact there may be lost")
    assert lines.count(said) == 1
    assert all(line.startswith("drumroll: ") for line in lines)
