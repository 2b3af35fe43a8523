"""``drumroll onsets`` end to end: outputs, overwrite protection, bad inputs."""

from __future__ import annotations

import io

import numpy as np
import pytest
import soundfile as sf

from drumroll.cli.main import main
from drumroll.onsets import COLUMNS, read_onsets
from tests.unit.audio.test_io import BAD, _write_bad
from tests.unit.onsets.test_detector import simulated_roll


@pytest.fixture(scope="module")
def roll_flac(tmp_path_factory):
    r = simulated_roll(21, snr_db=30, spurious=True)
    path = tmp_path_factory.mktemp("cli") / "roll.flac"
    sf.write(path, r.samples, r.sample_rate, subtype="PCM_24")
    return path, r.impact_times_s


def test_stdout_csv(roll_flac, capsys):
    path, truth = roll_flac
    assert main(["onsets", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == ",".join(COLUMNS)
    times = np.array([float(line.split(",")[0]) for line in out[1:]])
    assert abs(times[0] - truth[0]) < 1e-3


def test_files_plot_and_overwrite(roll_flac, tmp_path, capsys):
    path, _ = roll_flac
    csv, lab, png = tmp_path / "o.csv", tmp_path / "l.txt", tmp_path / "o.png"
    args = ["onsets", str(path), "-o", str(csv), "--labels", str(lab), "--plot", str(png),
            "--all-candidates"]
    assert main(args) == 0
    assert png.stat().st_size > 10_000
    np.testing.assert_allclose(read_onsets(csv).time_s, read_onsets(lab).time_s, atol=1e-6)
    before = csv.read_text()
    capsys.readouterr()
    assert main(args) == 2  # refuses to overwrite
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "already exists" in err[0]
    assert csv.read_text() == before
    assert main([*args, "--force"]) == 0


def test_the_recording_is_never_overwritten_by_its_onsets(roll_flac, tmp_path, capsys):
    """``-o`` naming the recording itself is refused, --force or not, and the recording
    is left as it was."""
    path, _ = roll_flac
    copy = tmp_path / "roll.flac"
    copy.write_bytes(path.read_bytes())
    for option in ("-o", "--labels"):
        assert main(["onsets", str(copy), option, str(copy), "--force"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "is an input of this command" in err[0]
    assert copy.read_bytes() == path.read_bytes()


@pytest.mark.parametrize("name", ["onsets.wav", "onsets"])
def test_onsets_are_written_only_under_a_name_estimate_reads_as_onsets(roll_flac, tmp_path,
                                                                       capsys, name):
    """CSV written to ``out.wav`` (or a name without a suffix) is a file that estimate
    then tries to decode as audio: refused before any work, naming the suffixes to use."""
    path, _ = roll_flac
    for option in ("-o", "--labels"):
        assert main(["onsets", str(path), option, str(tmp_path / name)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and ".csv" in err[0] and "reads it back as onsets" in err[0]
    assert list(tmp_path.iterdir()) == []


def test_channels_that_cancel_when_mixed_are_named(roll_flac, tmp_path, capsys):
    """A stereo file whose second channel is the first inverted (a microphone wired in
    reverse) mixes to silence: said so in one line, not "no impact-like sound in it"; the
    same channels in phase are read as the mono file is."""
    path, _ = roll_flac
    x, rate = sf.read(path)
    inverted, in_phase = tmp_path / "inverted.wav", tmp_path / "in_phase.wav"
    sf.write(inverted, np.stack([x, -x], axis=1), rate, subtype="PCM_24")
    sf.write(in_phase, np.stack([x, x], axis=1), rate, subtype="PCM_24")
    assert main(["onsets", str(inverted)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "channels cancel when mixed" in err[0]
    assert main(["onsets", str(in_phase)]) == 0
    stereo = capsys.readouterr().out
    assert main(["onsets", str(path)]) == 0
    assert capsys.readouterr().out == stereo


def test_a_stereo_file_with_a_silent_channel_reads_as_its_live_channel(roll_flac, tmp_path,
                                                                      capsys):
    """A channel of zeros beside the recording (its left or its right) once timed the roll on
    the silence, or ended in an internal error: exit 0 and the mono file's onsets."""
    path, _ = roll_flac
    x, rate = sf.read(path)
    def onsets(audio) -> np.ndarray:
        assert main(["onsets", str(audio)]) == 0
        return np.loadtxt(io.StringIO(capsys.readouterr().out), delimiter=",", skiprows=1)

    mono = onsets(path)
    for side, channels in (("left", [np.zeros_like(x), x]), ("right", [x, np.zeros_like(x)])):
        stereo = tmp_path / f"dead_{side}.wav"
        sf.write(stereo, np.stack(channels, axis=1), rate, subtype="PCM_24")
        np.testing.assert_allclose(onsets(stereo), mono, rtol=1e-6)


def test_a_high_pass_above_what_the_rate_allows_is_refused(roll_flac, capsys):
    """--highpass past a tenth of the sample rate leaves no band to analyse: it was capped
    without a word (30 kHz on a 44.1 kHz recording gave hundreds of "impacts")."""
    path, _ = roll_flac
    assert main(["onsets", str(path), "--highpass", "30000"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "leaves nothing to analyse" in err[0] and "at most" in err[0]


@pytest.mark.parametrize("kind", [*BAD, "noise"])
def test_bad_inputs_exit_2_with_one_line(tmp_path, capsys, kind):
    if kind == "noise":
        path = tmp_path / "noise.wav"
        sf.write(path, 0.1 * np.random.default_rng(0).standard_normal(3 * 22050), 22050)
    else:
        path = _write_bad(tmp_path, kind)
    assert main(["onsets", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("drumroll: error:")
    assert "Traceback" not in err[0]


def test_an_onset_file_given_as_the_recording_is_named_as_one(roll_flac, tmp_path, capsys):
    """``drumroll onsets onsets.csv`` called a healthy onset file "not a readable audio file,
    or its header is damaged"; it says what the file is and what fits it, and writes
    nothing. A file with an onset file's suffix that is no onset file either keeps the
    audio reader's word."""
    path, _ = roll_flac
    csv = tmp_path / "o.csv"
    assert main(["onsets", str(path), "-o", str(csv), "-q"]) == 0
    count = len(read_onsets(csv).time_s)
    capsys.readouterr()
    out = tmp_path / "again.csv"
    assert main(["onsets", str(csv), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"an onset file ({count} onsets), not a recording" in err[0]
    assert f"drumroll estimate {csv} --prior CONFIG" in err[0]
    assert not out.exists()
    junk = tmp_path / "junk.txt"
    junk.write_text("hello there\n")
    assert main(["onsets", str(junk)]) == 2
    assert "not a readable audio file" in capsys.readouterr().err
