"""``drumroll simulate`` through the real command line, in a temporary folder."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from configs import PAPER_STICK
from drumroll.cli.main import main
from drumroll.physics import StickGeometry, bounce_sequence

BASE = textwrap.dedent("""\
    model = "pendulum"

    """) + PAPER_STICK + textwrap.dedent("""\

    [priors]
    alpha = { dist = "uniform", low = 0.5, high = 1.0 }
    pivot_mm = { dist = "normal", mu = 131, sigma = 2 }
    height_mm = { dist = "normal", mu = 80, sigma = 3 }

    [simulate]
    alpha = 0.88
    pivot_mm = 131
    height_mm = 80
    n_bounces = 12
    sample_rate = 22050

    [simulate.disturbances]
    snr_db = 35
    lead_in_s = 0.2
    tail_s = 0.3
    """)


def write_config(tmp_path: Path, text: str = BASE, **simulate: object) -> Path:
    lines = [f"{k} = {json.dumps(v)}" for k, v in simulate.items()]
    text = "".join(line for line in text.splitlines(keepends=True)
                   if line.split(" = ")[0] not in simulate)  # overridden keys
    text = text.replace("[simulate]\n", "[simulate]\n" + "".join(f"{x}\n" for x in lines))
    path = tmp_path / "config.toml"
    path.write_text(text)
    return path


def simulate(tmp_path: Path, config: Path, out: str = "roll.wav", *extra: str,
             capsys=None) -> tuple[int, str]:
    code = main(["simulate", str(config), "-o", str(tmp_path / out), *extra])
    err = capsys.readouterr().err if capsys is not None else ""
    return code, err


@pytest.mark.parametrize("suffix, subtype, sf_subtype", [
    (".wav", "PCM_16", "PCM_16"), (".wav", "PCM_24", "PCM_24"), (".wav", "FLOAT", "FLOAT"),
    (".flac", "PCM_16", "PCM_16"), (".flac", "PCM_24", "PCM_24"), (".ogg", None, "VORBIS"),
])
def test_containers_and_subtypes(tmp_path, suffix, subtype, sf_subtype, capsys):
    extra = {"subtype": subtype} if subtype else {}
    config = write_config(tmp_path, **extra)
    code, err = simulate(tmp_path, config, f"roll{suffix}", capsys=capsys)
    assert code == 0, err
    info = sf.info(tmp_path / f"roll{suffix}")
    assert info.subtype == sf_subtype and info.samplerate == 22050 and info.channels == 1
    truth = json.loads((tmp_path / "roll.truth.json").read_text())
    assert truth["frames"] == info.frames
    assert len(truth["impact_times_s"]) == 13


@pytest.mark.parametrize("rate", [22050, 44100, 96000])
@pytest.mark.parametrize("channels", [1, 2])
def test_rates_and_channels(tmp_path, rate, channels, capsys):
    config = write_config(tmp_path, sample_rate=rate, channels=channels, n_bounces=6)
    code, err = simulate(tmp_path, config, "roll.flac", "--truth",
                         str(tmp_path / "t.json"), capsys=capsys)
    assert code == 0, err
    data, fs = sf.read(tmp_path / "roll.flac", always_2d=True)
    assert fs == rate and data.shape[1] == channels
    truth = json.loads((tmp_path / "t.json").read_text())
    assert truth["sample_rate"] == rate and truth["channels"] == channels
    # Nothing of the first impact before its truth time (only noise: far below the hit).
    n0 = int(np.ceil(truth["impact_times_s"][0] * rate))
    before = np.max(np.abs(data[n0 - rate // 20:n0 - 2, 0]))
    after = np.max(np.abs(data[n0:n0 + rate // 100, 0]))
    assert after > 10 * before


def test_truth_matches_the_physics_and_the_audio(tmp_path, capsys):
    config = write_config(tmp_path, subtype="FLOAT")
    code, err = simulate(tmp_path, config, "roll.wav", "--seed", "5", capsys=capsys)
    assert code == 0, err
    truth = json.loads((tmp_path / "roll.truth.json").read_text())
    stick = StickGeometry("cylinder-cone", 0.348, 0.060, 0.0075)
    b = bounce_sequence("pendulum", alpha=0.88, n_flights=12, pivot=0.131, height=0.080,
                        stick=stick)
    times = np.asarray(truth["impact_times_s"])
    # Each impact holds the stick for the drum's contact time, 0.8 ms at 1 m/s scaled as
    # speed^(-1/5) (Hertz), and the next flight starts when it ends.
    speeds = np.ravel(b.impact_tip_speeds)
    contact = 0.8e-3 * speeds ** -0.2
    delays = np.concatenate(([0.0], np.cumsum(contact[:-1])))
    np.testing.assert_allclose(times - times[0], np.ravel(b.impacts) + delays, atol=1e-12)
    np.testing.assert_allclose(truth["impact_speeds_m_s"], speeds)
    assert truth["physics"]["contact_ms"] == pytest.approx(1e3 * contact[0], rel=1e-12)
    assert truth["seed"] == 5 and truth["drumroll_version"]
    assert truth["simulate"]["alpha"] == 0.88 and truth["simulate"]["pivot_mm"] == 131
    assert truth["stick"]["length_mm"] == pytest.approx(348)
    assert len(truth["local_snr_db"]) == 13
    data, fs = sf.read(tmp_path / "roll.wav")
    assert np.max(np.abs(data)) == pytest.approx(10 ** (-1 / 20), rel=1e-6)  # FLOAT: exact
    n0 = int(np.ceil(times[0] * fs))
    assert np.max(np.abs(data[n0:n0 + 50])) > 20 * np.max(np.abs(data[n0 - 500:n0]))


def test_deterministic_for_a_seed_and_seed_matters(tmp_path, capsys):
    config = write_config(tmp_path, jitter_ms=0.2)
    for name, seed in (("a", "3"), ("b", "3"), ("c", "4")):
        code, err = simulate(tmp_path, config, f"{name}.wav", "--seed", seed, capsys=capsys)
        assert code == 0, err
    a, b, c = (sf.read(tmp_path / f"{n}.wav")[0] for n in "abc")
    np.testing.assert_array_equal(a, b)
    assert a.shape != c.shape or not np.array_equal(a, c)
    ta, tb, tc = (json.loads((tmp_path / f"{n}.truth.json").read_text()) for n in "abc")
    ta.pop("recording"), tb.pop("recording")
    assert ta == tb and ta["impact_times_s"] != tc["impact_times_s"]
    # The jitter moved the impacts off the model's times, by about 0.2 ms.
    offsets = np.subtract(ta["impact_times_s"], ta["model_impact_times_s"])
    assert 0.05e-3 < np.std(offsets) < 0.5e-3


def test_min_tip_speed_ends_the_roll(tmp_path, capsys):
    text = BASE.replace("n_bounces = 12\n", "min_tip_speed_m_s = 0.3\n")
    code, err = simulate(tmp_path, write_config(tmp_path, text), capsys=capsys)
    assert code == 0, err
    speeds = json.loads((tmp_path / "roll.truth.json").read_text())["impact_speeds_m_s"]
    assert min(speeds) >= 0.3 and min(speeds) * 0.88 < 0.3


def test_drum_room_and_disturbance_sections(tmp_path, capsys):
    text = BASE + textwrap.dedent("""\
        spurious = true
        hum_hz = 60
        [simulate.drum]
        fundamental_hz = 180
        snare_band_hz = [1500, 9000]
        [simulate.room]
        echo = true
        echo_delay_s = [0.006, 0.006]
        reverb_time_s = 0.3
        """)
    code, err = simulate(tmp_path, write_config(tmp_path, text), capsys=capsys)
    assert code == 0, err
    truth = json.loads((tmp_path / "roll.truth.json").read_text())
    assert truth["spurious_kinds"] == ["tap", "knock"]
    assert truth["echo_delay_s"] == [pytest.approx(0.006)]
    assert truth["simulate"]["drum"]["fundamental_hz"] == 180
    assert truth["simulate"]["disturbances"]["hum_hz"] == 60


def test_refuses_to_overwrite_without_force(tmp_path, capsys):
    config = write_config(tmp_path)
    assert simulate(tmp_path, config, capsys=capsys)[0] == 0
    before = (tmp_path / "roll.wav").read_bytes()
    code, err = simulate(tmp_path, config, "roll.wav", "--seed", "9", capsys=capsys)
    assert code == 2 and "already exists" in err and "--force" in err
    assert (tmp_path / "roll.wav").read_bytes() == before
    code, err = simulate(tmp_path, config, "roll.wav", "--seed", "9", "--force", capsys=capsys)
    assert code == 0 and (tmp_path / "roll.wav").read_bytes() != before


BAD = {  # name: (text appended to BASE or (old, new) replacement, expected parts)
    "unknown key": (("alpha = 0.88\n", "alpha = 0.88\nalpah = 0.9\n"),
                    ["simulate.alpah", "did you mean 'alpha'"]),
    "unknown drum key": ("[simulate.drum]\nfundamental = 200\n",
                         ["simulate.drum.fundamental", "fundamental_hz"]),
    "bad drum value": ("[simulate.drum]\ndecay_s = -1\n", ["simulate.drum.decay_s", "> 0"]),
    "bad room type": ("[simulate.room]\necho = 1\n", ["simulate.room.echo", "true or false"]),
    "bad tuple": ("[simulate.room]\necho_delay_s = [0.01]\n",
                  ["simulate.room.echo_delay_s", "2 numbers"]),
    "bad snr": (("snr_db = 35", 'snr_db = "loud"'), ["simulate.disturbances.snr_db", "number"]),
    "bad subsection": (("[simulate.disturbances]", "[simulate.disturbance]"),
                       ["simulate.disturbance", "did you mean 'disturbances'"]),
}


@pytest.mark.parametrize("name", BAD)
def test_bad_subsection_values(tmp_path, name, capsys):
    change, expected = BAD[name]
    text = BASE.replace(*change) if isinstance(change, tuple) else BASE + change
    code, err = simulate(tmp_path, write_config(tmp_path, text), capsys=capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    for part in expected:
        assert part in err


@pytest.mark.parametrize("change, expected", [
    (("alpha = 0.88", "alpha = 1.5"), "simulate.alpha"),
    (("alpha = 0.88\n", ""), "simulate.alpha: missing"),
    (("height_mm = 80\n", "height_mm = 500\n"), "tip cannot reach"),
    (("pivot_mm = 131\n", "pivot_mm = 250\n"), "centre of mass"),
    (("n_bounces = 12", "n_bounces = 12\nmin_tip_speed_m_s = 0.1"), "not both"),
    (("n_bounces = 12", "n_bounces = 2.5"), "simulate.n_bounces"),
    (("sample_rate = 22050", "sample_rate = 100"), "simulate.sample_rate"),
    (("sample_rate = 22050", "sample_rate = 22050\nsubtype = \"PCM_32\""), "simulate.subtype"),
    (("sample_rate = 22050", "sample_rate = 22050\nchannels = 0"), "simulate.channels"),
    (("[simulate]\n", "[simulat]\n"), "did you mean 'simulate'"),
])
def test_bad_configs_exit_2_with_one_line(tmp_path, change, expected, capsys):
    assert change[0] in BASE
    code, err = simulate(tmp_path, write_config(tmp_path, BASE.replace(*change)), capsys=capsys)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert expected in err
    assert not (tmp_path / "roll.wav").exists()


def test_missing_section_and_bad_outputs(tmp_path, capsys):
    no_sim = BASE[:BASE.index("[simulate]")]
    code, err = simulate(tmp_path, write_config(tmp_path, no_sim), capsys=capsys)
    assert code == 2 and "simulate: missing section" in err
    config = write_config(tmp_path, subtype="FLOAT")
    code, err = simulate(tmp_path, config, "roll.flac", capsys=capsys)
    assert code == 2 and "FLAC cannot hold FLOAT" in err
    code, err = simulate(tmp_path, config, "roll.mp3", capsys=capsys)
    assert code == 2 and "unknown audio container" in err
    code, err = simulate(tmp_path, config, "nowhere/roll.wav", capsys=capsys)
    assert code == 2 and "no such directory" in err


def test_subprocess_entry_point(tmp_path):
    config = write_config(tmp_path, n_bounces=3)
    result = subprocess.run([sys.executable, "-m", "drumroll", "simulate", str(config), "-o",
                             str(tmp_path / "roll.wav")], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert "4 impacts" in result.stdout
    bad = write_config(tmp_path, BASE.replace("alpha = 0.88", "alpha = \"high\""))
    result = subprocess.run([sys.executable, "-m", "drumroll", "simulate", str(bad), "-o",
                             str(tmp_path / "x.wav")], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1
    assert "simulate.alpha" in result.stderr


def test_count_makes_numbered_recordings_with_consecutive_seeds(tmp_path, capsys):
    config = write_config(tmp_path, jitter_ms=0.2)
    code, err = simulate(tmp_path, config, "roll.wav", "--count", "3", "--seed", "3",
                         capsys=capsys)
    assert code == 0, err
    names = sorted(p.name for p in tmp_path.glob("roll-*"))
    assert names == ["roll-000.truth.json", "roll-000.wav", "roll-001.truth.json",
                     "roll-001.wav", "roll-002.truth.json", "roll-002.wav"]
    seeds = [json.loads((tmp_path / f"roll-00{i}.truth.json").read_text())["seed"]
             for i in range(3)]
    assert seeds == [3, 4, 5]
    # each the recording a single run with its seed makes
    assert simulate(tmp_path, config, "four.wav", "--seed", "4", capsys=capsys)[0] == 0
    np.testing.assert_array_equal(sf.read(tmp_path / "four.wav")[0],
                                  sf.read(tmp_path / "roll-001.wav")[0])
    # not a terminal: news lines, no bar; then refused before any work without --force
    assert err.count("impacts (") == 3 and "\r" not in err
    code, err = simulate(tmp_path, config, "roll.wav", "--count", "3", capsys=capsys)
    assert code == 2 and "roll-000.wav" in err
    assert main(["simulate", str(config), "-o", str(tmp_path / "x.wav"), "--count", "2",
                 "--truth", str(tmp_path / "t.json")]) == 2
