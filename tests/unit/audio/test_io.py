"""Reading recordings in every container, encoding, rate and channel count; bad inputs."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import soundfile as sf

from drumroll.audio import iter_blocks, probe, read_audio
from drumroll.errors import AudioError, DrumrollWarning
from drumroll.onsets import detect
from tests.unit.onsets.test_detector import score, simulated_roll

CASES = [  # (format, subtype, extension, sample rate, channels, lossy)
    ("WAV", "PCM_16", "wav", 44100, 1, False),
    ("WAV", "PCM_24", "wav", 48000, 2, False),
    ("WAV", "PCM_32", "wav", 96000, 1, False),
    ("WAV", "FLOAT", "wav", 22050, 2, False),
    ("WAV", "DOUBLE", "wav", 44100, 1, False),
    ("WAV", "PCM_U8", "wav", 44100, 1, False),
    ("FLAC", "PCM_16", "flac", 44100, 2, False),
    ("FLAC", "PCM_24", "flac", 96000, 1, False),
    ("OGG", "VORBIS", "ogg", 44100, 1, True),
]
if "MP3" in sf.available_formats():
    CASES.append(("MP3", "MPEG_LAYER_III", "mp3", 44100, 1, True))


@pytest.mark.parametrize("fmt, subtype, ext, sr, channels, lossy", CASES)
def test_every_container_gives_the_onsets(tmp_path, fmt, subtype, ext, sr, channels, lossy):
    r = simulated_roll(11, sr=sr, snr_db=40)
    x, truth, audible = r.samples, r.impact_times_s, r.local_snr_db >= 0
    data = np.column_stack([x, 0.9 * x]) if channels == 2 else x
    path = tmp_path / f"roll.{ext}"
    sf.write(path, data, sr, format=fmt, subtype=subtype)
    info = probe(path)
    assert info.sample_rate == sr and info.channels == channels
    table = detect(path)
    # Lossy codecs shift and smear the click: judge them at the container's own tolerance.
    f1, mad = score(table.time_s - (np.median(table.time_s[:3] - truth[:3]) if lossy else 0),
                    truth, audible)
    assert f1 >= 0.9
    assert mad <= (1e-3 if lossy else 0.2e-3)


def test_blocks_equal_whole_read(tmp_path):
    rng = np.random.default_rng(0)
    x = 0.1 * rng.standard_normal((10_000, 2))
    path = tmp_path / "a.wav"
    sf.write(path, x, 8000, subtype="FLOAT")
    whole, _sr = read_audio(path)
    parts = np.concatenate(list(iter_blocks(path, block_frames=777)))
    np.testing.assert_allclose(whole, x.mean(axis=1), atol=1e-7)
    np.testing.assert_array_equal(whole, parts)


def _write_bad(tmp_path, kind):
    p = tmp_path / f"{kind}.wav"
    if kind == "missing":
        return p
    if kind == "directory":
        p.mkdir()
    elif kind == "not_audio":
        p.write_text("this is not audio\n" * 20)
    elif kind == "truncated_header":
        sf.write(p, np.zeros(100), 8000)
        p.write_bytes(p.read_bytes()[:30])
    elif kind == "zero_length":
        sf.write(p, np.zeros(0), 8000)
    elif kind == "empty_file":
        p.write_bytes(b"")
    elif kind == "silence":
        sf.write(p, np.zeros(8000), 8000)
    elif kind == "nan":
        x = np.zeros(8000)
        x[100] = np.nan
        sf.write(p, x, 8000, subtype="FLOAT")
    elif kind == "inf":
        x = 0.1 * np.ones(8000)
        x[5000] = np.inf
        sf.write(p, x, 8000, subtype="DOUBLE")
    return p


BAD = ["missing", "directory", "not_audio", "truncated_header", "zero_length", "empty_file",
       "silence", "nan", "inf"]


@pytest.mark.parametrize("kind", BAD)
def test_bad_inputs_raise_one_line_naming_the_file(tmp_path, kind):
    path = _write_bad(tmp_path, kind)
    with pytest.raises(AudioError) as err:
        read_audio(path)
    msg = str(err.value)
    assert str(path) in msg and "\n" not in msg


def test_clipping_warns_and_carries_on(tmp_path):
    r = simulated_roll(4)
    x, sr = r.samples, r.sample_rate
    path = tmp_path / "clip.wav"
    sf.write(path, np.clip(4 * x, -1, 1), sr, subtype="PCM_16")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read_audio(path)
    assert any(issubclass(w.category, DrumrollWarning) and "clipped" in str(w.message)
               for w in caught)


@pytest.mark.parametrize(("fmt", "subtype", "suffix"), [
    ("WAV", "PCM_16", ".wav"), ("OGG", "VORBIS", ".ogg"), ("MP3", "MPEG_LAYER_III", ".mp3")])
def test_a_file_cut_short_is_read_with_a_warning(tmp_path, fmt, subtype, suffix):
    """A recording whose upload or copy stopped half-way: its header (WAV's data chunk, an
    MP3's Xing frame count) or its last Ogg page says so, and what is there is analysed with
    one warning (it was analysed without a word); the whole file gives none."""
    rng = np.random.default_rng(0)
    x = 0.1 * rng.standard_normal(44100 * 3)
    whole = tmp_path / f"whole{suffix}"
    sf.write(whole, x, 44100, format=fmt, subtype=subtype)
    cut = tmp_path / f"cut{suffix}"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DrumrollWarning)
        read_audio(whole)
    assert not [w for w in caught if "cut short" in str(w.message)]
    with pytest.warns(DrumrollWarning, match="the file is cut short") as caught:
        y, _ = read_audio(cut)
    assert 0.3 * x.size < y.size < 0.7 * x.size
    # one line (a warning repeated from one place is shown once)
    assert len({str(w.message) for w in caught if "cut short" in str(w.message)}) == 1
