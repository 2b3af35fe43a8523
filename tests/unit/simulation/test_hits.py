"""Recordings made of real recorded hits in a measured room (``data/samples``)."""

from __future__ import annotations

import json
import os
import textwrap
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from scipy import signal

from configs import PAPER_STICK
from drumroll.cli.main import main
from drumroll.physics import StickGeometry, bounce_sequence
from drumroll.simulation import Disturbances, ExtraHit, HitBank, MeasuredRoom, render_hits
from drumroll.simulation.render import LOCAL_SNR_HIGHPASS_HZ, LOCAL_SNR_WINDOW_S
from paths import DATA

SAMPLES = DATA / "samples"
PEARL = [SAMPLES / "avl" / f"38-PearlSnare-{i}.flac" for i in range(1, 6)]
CLAVES = SAMPLES / "js30" / "claves-1.ogg"
LIVE = SAMPLES / "rooms" / "genesis6_live_room.flac"
HALL = SAMPLES / "rooms" / "arthur_sykes_rymer_auditorium.flac"
QUIET = Disturbances(snr_db=None, lead_in_s=0.1, tail_s=0.5)


def _rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def _onset(rendering, k: int = 0) -> int:
    n0 = rendering.impact_times_s[k] * rendering.sample_rate
    assert n0 == pytest.approx(round(n0), abs=1e-6)  # impacts sit on samples
    return round(n0)


# --- where a sample starts ------------------------------------------------------------------

def test_sample_start_is_the_first_sound_of_the_file():
    # In the file, the softest Pearl layer's samples 0-31 are its noise floor (below -60 dB
    # re peak) and sample 32 is where the hit rises through -40 dB re peak (1 %).
    x, fs = sf.read(PEARL[0])
    a = np.abs(x)
    assert fs == 44100 and np.all(a[:32] < 1e-3 * a.max()) and a[32] >= 0.01 * a.max()
    bank = HitBank.load([PEARL[0]], 44100, level_spread_db=0)
    assert bank.starts_s[0] * fs == pytest.approx(32)
    r = render_hits([0.0], [1.0], bank=bank, disturbances=QUIET, rng=_rng(), peak_dbfs=0)
    y, n0 = r.samples, _onset(r)
    assert r.impact_times_s[0] == pytest.approx(0.1)  # the requested time plus the lead-in
    assert np.all(y[:n0] == 0.0) and y[n0] != 0.0
    # From the truth time on, the recording is the file from its sample 32 on, scaled.
    m = min(len(x) - 32, len(y) - n0)
    np.testing.assert_allclose(y[n0:n0 + m] * a.max() / np.abs(y).max(), x[32:32 + m], atol=1e-12)


@pytest.mark.parametrize("rate", [22050, 48000, 96000])
def test_resampled_sample_starts_where_the_file_does(rate):
    bank = HitBank.load([PEARL[0]], rate, level_spread_db=0)
    assert bank.starts_s[0] == pytest.approx(32 / 44100, abs=1.5 / rate)
    r = render_hits([0.0], [1.0], bank=bank, disturbances=QUIET, rng=_rng())
    n0 = _onset(r)
    assert np.all(r.samples[:n0] == 0.0) and abs(r.samples[n0]) > 0
    # The resampler's pre-ringing was cut: the first sample is a real part of the attack.
    assert abs(r.samples[n0]) >= 0.01 * np.max(np.abs(r.samples))


def test_a_lossy_sample_starts_at_its_transient_not_its_pre_echo():
    # The claves (OGG Vorbis) strike at 17.2 ms; the 2 ms before it hold the codec's
    # pre-echo: noise between 1 % and 10 % of the peak.
    x, fs = sf.read(CLAVES)
    a = np.abs(x.mean(axis=1))
    strike = int(np.argmax(a >= 0.1 * a.max()))
    assert strike / fs == pytest.approx(17.21e-3, abs=0.05e-3)
    assert np.max(a[round(0.0155 * fs):strike]) > 0.03 * a.max()
    for rate in (22050, 44100, 96000):
        assert HitBank.load([CLAVES], rate).starts_s[0] == pytest.approx(strike / fs,
                                                                         abs=1.5 / rate)


def test_a_file_that_starts_with_its_sound_starts_at_once(tmp_path):
    x, fs = sf.read(PEARL[4])
    x = x[int(np.argmax(np.abs(x) > 0.3)):]  # cut into the attack: no floor to measure
    sf.write(tmp_path / "cut.wav", x, fs, subtype="FLOAT")
    assert HitBank.load([tmp_path / "cut.wav"], fs).starts_s == (0.0,)


def test_a_noisy_floor_raises_the_start_threshold(tmp_path):
    x, fs = sf.read(PEARL[4])
    noise = 0.005 * np.max(np.abs(x)) * np.random.default_rng(3).standard_normal(4410)
    noisy = np.concatenate([noise, x[44:]])  # the hit's sound from its start, after 100 ms
    sf.write(tmp_path / "noisy.wav", noisy, fs, subtype="FLOAT")
    start = round(HitBank.load([tmp_path / "noisy.wav"], fs).starts_s[0] * fs)
    # Noise peaks at ~2 % of the hit's peak; 20 dB above its RMS (5 %) keeps it all out.
    assert start >= 4410
    assert np.all(np.abs(noisy[4410:start]) < 0.06 * np.max(np.abs(x)))


# --- layers and levels ----------------------------------------------------------------------

def test_louder_impacts_use_louder_layers():
    bank = HitBank.load(PEARL, 44100)
    drops = np.array([0.0, 3.0, 7.0, 13.0, 19.0, 25.0, 31.0])  # dB below the loudest
    speeds = 1.2 * 10 ** (-drops / (20 * 1.2))
    layers, nominal, _ = bank.plan(speeds, _rng())
    np.testing.assert_allclose(nominal, -drops, atol=1e-9)
    assert list(layers) == [4, 4, 3, 2, 1, 0, 0]  # one softer per 6 dB, none below the softest
    wide = HitBank.load(PEARL, 44100, layer_db=12.0)
    assert list(wide.plan(speeds, _rng())[0]) == [4, 4, 4, 3, 3, 2, 2]


@pytest.mark.parametrize("exponent", [1.2, 2.0])
def test_hit_levels_follow_the_exponent(exponent):
    # A single layer (a ball on claves): the rendered hits differ in level only.
    bank = HitBank.load([CLAVES], 22050, level_exponent=exponent, level_spread_db=0)
    speeds = np.array([2.0, 1.5, 1.0, 0.5, 0.25])
    times = 0.5 * np.arange(speeds.size)  # a claves hit rings 0.4 s: no overlap
    r = render_hits(times, speeds, bank=bank, disturbances=QUIET, rng=_rng())
    n = round(0.010 * 22050)
    rms = np.array([np.sqrt(np.mean(r.samples[_onset(r, k):_onset(r, k) + n] ** 2))
                    for k in range(speeds.size)])
    np.testing.assert_allclose(20 * np.log10(rms / rms[0]),
                               20 * exponent * np.log10(speeds / speeds[0]), atol=1e-9)


def test_level_spread_is_gaussian_with_the_given_sd():
    bank = HitBank.load([CLAVES], 22050, level_spread_db=1.5)
    speeds = np.full(4000, 1.0)
    _, nominal, level = bank.plan(speeds, _rng(7))
    assert np.all(nominal == 0.0)
    assert np.std(level) == pytest.approx(1.5, rel=0.05) and abs(np.mean(level)) < 0.1


# --- local SNR ------------------------------------------------------------------------------

def test_local_snr_alone_is_high_and_after_a_loud_hit_low():
    bank = HitBank.load(PEARL, 44100, level_spread_db=0)
    faint = 10 ** (-40 / (20 * 1.2))  # 40 dB below the first hit
    both = render_hits([0.0, 0.004], [1.0, faint], bank=bank, disturbances=QUIET, rng=_rng())
    assert both.local_snr_db[0] > 100  # nothing else in its first 3 ms
    assert both.local_snr_db[1] < -10  # lost in the first hit's ring
    # The definition, by hand: the faint hit alone against the rest, 3 ms, 1.5 kHz high-pass.
    first = render_hits([0.0, 0.004], [1.0, faint], bank=bank, disturbances=QUIET,
                        rng=_rng())
    alone = render_hits([0.0], [1.0], bank=bank, disturbances=QUIET, rng=_rng())
    mix = both.samples / both.scale
    first_only = np.zeros_like(mix)
    first_only[:len(alone.samples)] = (alone.samples / alone.scale)[:len(mix)]
    own = mix - first_only
    sos = signal.butter(4, LOCAL_SNR_HIGHPASS_HZ, btype="highpass", fs=44100, output="sos")
    n0, n = _onset(first, 1), round(LOCAL_SNR_WINDOW_S * 44100)
    own_hp = signal.sosfilt(sos, own)[n0:n0 + n]
    rest_hp = signal.sosfilt(sos, first_only)[n0:n0 + n]
    expected = 10 * np.log10(np.sum(own_hp**2) / np.sum(rest_hp**2))
    assert both.local_snr_db[1] == pytest.approx(expected, abs=0.01)


def test_local_snr_counts_noise_and_room():
    bank = HitBank.load(PEARL, 44100, level_spread_db=0)
    clean = render_hits([0.0], [1.0], bank=bank, disturbances=QUIET, rng=_rng())
    noisy = render_hits([0.0], [1.0], bank=bank, rng=_rng(),
                        disturbances=Disturbances(snr_db=20, lead_in_s=0.1, tail_s=0.5))
    roomy = render_hits([0.0], [1.0], bank=bank, disturbances=QUIET, rng=_rng(),
                        room=MeasuredRoom.load(LIVE, 44100, wet_db=-6))
    assert clean.local_snr_db[0] == 200.0  # capped: nothing else at all
    assert 10 < noisy.local_snr_db[0] < 60
    assert 0 < roomy.local_snr_db[0] < 60


# --- the measured room ----------------------------------------------------------------------

def test_direct_sound_of_the_measured_responses():
    # The auditorium's direct sound is its peak, sample 2179 of the 96 kHz file (22.70 ms).
    # The live room's first arrival (6.9-7.0 ms) is 3 dB below a reflection at 16.9 ms.
    assert MeasuredRoom.load(HALL, 96000).direct_s == pytest.approx(2179 / 96000, abs=2e-5)
    h, fs = sf.read(LIVE)
    assert np.argmax(np.abs(h)) / fs == pytest.approx(0.01685, abs=1e-4)
    assert 6.8e-3 < MeasuredRoom.load(LIVE, 96000).direct_s < 7.1e-3


@pytest.mark.parametrize("ir, rate", [(LIVE, 44100), (HALL, 22050), (HALL, 96000)])
def test_room_adds_energy_after_the_direct_sound_only(ir, rate):
    bank = HitBank.load([PEARL[4]], rate, level_spread_db=0)
    quiet = Disturbances(snr_db=None, lead_in_s=0.1, tail_s=1.5)
    dry = render_hits([0.0], [1.0], bank=bank, disturbances=quiet, rng=_rng())
    wet = render_hits([0.0], [1.0], bank=bank, disturbances=quiet, rng=_rng(),
                      room=MeasuredRoom.load(ir, rate, wet_db=-12))
    n0 = _onset(dry)
    assert _onset(wet) == n0 and np.all(wet.samples[:n0] == 0.0)
    added = wet.samples / wet.scale - dry.samples / dry.scale
    direct = n0 + round(1e-3 * rate)  # the response's own direct sound: its first 1 ms
    assert np.max(np.abs(added[:direct])) < 1e-12
    assert np.max(np.abs(added[direct:direct + round(5e-3 * rate)])) > 1e-3
    # Its energy is wet_db relative to the dry sound, whatever the rate.
    ratio = np.sum(added**2) / np.sum((dry.samples / dry.scale) ** 2)
    assert 10 * np.log10(ratio) == pytest.approx(-12.0, abs=0.01)


# --- channels, clipping, extra hits ---------------------------------------------------------

def test_second_channel_is_a_farther_microphone():
    bank = HitBank.load([PEARL[4]], 48000, level_spread_db=0)
    r = render_hits([0.0], [1.0], bank=bank, disturbances=QUIET, rng=_rng(2), channels=2,
                    room=MeasuredRoom.load(HALL, 48000))
    x = r.samples
    first = [int(np.flatnonzero(x[:, c])[0]) for c in range(2)]
    assert first[0] == _onset(r)
    delay = first[1] - first[0]
    assert 0.3e-3 * 48000 <= delay <= 2e-3 * 48000
    assert delay == round(r.channel_delays_s[1] * 48000)
    # Weaker direct sound, same room: more reverberant.
    n = round(1e-3 * 48000)
    direct = [np.sum(x[f:f + n, c] ** 2) for c, f in enumerate(first)]
    late = [np.sum(x[f + round(0.05 * 48000):, c] ** 2) for c, f in enumerate(first)]
    assert direct[1] < direct[0] and direct[1] / late[1] < direct[0] / late[0]


def test_channels_have_their_own_noise():
    bank = HitBank.load([PEARL[4]], 22050)
    r = render_hits([0.0], [1.0], bank=bank, rng=_rng(), channels=2,
                    disturbances=Disturbances(snr_db=20, lead_in_s=0.3, tail_s=0.2))
    lead = r.samples[:round(0.25 * 22050)]
    assert abs(np.corrcoef(lead[:, 0], lead[:, 1])[0, 1]) < 0.2


def test_clipping_drives_the_mix_past_full_scale():
    bank = HitBank.load(PEARL, 44100)
    times, speeds = [0.0, 0.2, 0.35], [1.0, 0.8, 0.6]
    plain = render_hits(times, speeds, bank=bank, disturbances=QUIET, rng=_rng(), peak_dbfs=0)
    clipped = render_hits(times, speeds, bank=bank, disturbances=QUIET, rng=_rng(),
                          peak_dbfs=0, clip_db=6)
    expected = np.clip(plain.samples * 10 ** (6 / 20), -1, 1)
    np.testing.assert_allclose(clipped.samples, expected, atol=1e-12)
    n_full = int(np.sum(np.abs(clipped.samples) >= 1.0))
    assert n_full > 3 and clipped.truth()["clipped_samples"] == n_full
    np.testing.assert_array_equal(clipped.impact_times_s, plain.impact_times_s)
    assert np.max(np.abs(plain.samples)) == pytest.approx(1.0)


def test_extra_hits_are_reported_as_spurious():
    bank = HitBank.load(PEARL, 44100)
    side = HitBank.load([SAMPLES / "avl" / "37-SideStick-3.flac"], 44100)
    tom = HitBank.load([SAMPLES / "avl" / "45-Pearl12Tom-3.flac"], 44100, names=["tom.flac"])
    r = render_hits([0.0, 0.25, 0.45], [1.0, 0.9, 0.8], bank=bank, disturbances=QUIET,
                    rng=_rng(), extra_hits=[ExtraHit(side, -0.35, level_db=-6),
                                            ExtraHit(tom, 0.45, after_last=True, kind="tom")])
    t0, t_last = r.impact_times_s[0], r.impact_times_s[-1]
    np.testing.assert_allclose(r.spurious_times_s, [t0 - 0.35, t_last + 0.45], atol=1 / 44100)
    assert r.spurious_kinds == ("37-SideStick-3", "tom")
    assert r.spurious_times_s[0] >= 0.2  # lead-in lengthened to hold the side-stick
    n_side = round(r.spurious_times_s[0] * 44100)
    assert np.all(r.samples[:n_side] == 0.0) and r.samples[n_side] != 0.0
    assert r.duration_s >= r.spurious_times_s[1] + 0.5
    assert r.truth()["recorded_hits"]["extra_hits"][1]["file"] == "tom.flac"


def test_same_seed_same_recording():
    bank = HitBank.load(PEARL, 22050)
    room = MeasuredRoom.load(LIVE, 22050)
    a, b, c = (render_hits([0.0, 0.2, 0.35], [1.0, 0.8, 0.6], bank=bank, room=room, rng=_rng(s),
                           channels=2) for s in (1, 1, 2))
    np.testing.assert_array_equal(a.samples, b.samples)
    assert not np.array_equal(a.samples, c.samples)


# --- drumroll simulate ----------------------------------------------------------------------

def _base(tmp_path: Path) -> str:
    rel = Path(os.path.relpath(SAMPLES, tmp_path)).as_posix()
    hits = ", ".join(f'"{rel}/avl/38-PearlSnare-{i}.flac"' for i in range(1, 6))
    return textwrap.dedent("""\
        model = "pendulum"

        """) + PAPER_STICK + textwrap.dedent(f"""\

        [priors]
        alpha = {{ dist = "uniform", low = 0.5, high = 1.0 }}
        pivot_mm = {{ dist = "normal", mu = 131, sigma = 2 }}
        height_mm = {{ dist = "normal", mu = 80, sigma = 3 }}

        [simulate]
        alpha = 0.88
        pivot_mm = 131
        height_mm = 80
        n_bounces = 12
        sample_rate = 22050
        subtype = "FLOAT"
        hits = [{hits}]
        room = "{rel}/rooms/genesis6_live_room.flac"
        wet_db = -14

        [simulate.disturbances]
        snr_db = false
        lead_in_s = 0.2
        tail_s = 0.3
        """)


def _simulate(tmp_path: Path, text: str, capsys, *extra: str) -> tuple[int, str]:
    config = tmp_path / "config.toml"
    config.write_text(text)
    code = main(["simulate", str(config), "-o", str(tmp_path / "roll.wav"), *extra])
    return code, capsys.readouterr().err


def test_simulate_end_to_end(tmp_path, capsys, monkeypatch):
    text = _base(tmp_path).replace("wet_db = -14\n", "wet_db = -14\nchannels = 2\n")
    monkeypatch.chdir(tmp_path.parent)  # file names are relative to the config, not here
    code, err = _simulate(tmp_path, text, capsys, "--seed", "4")
    assert code == 0, err
    truth = json.loads((tmp_path / "roll.truth.json").read_text())
    data, fs = sf.read(tmp_path / "roll.wav", always_2d=True)
    assert fs == 22050 and data.shape == (truth["frames"], 2)
    # The physics is the model's; each impact lands on the sample nearest its model time.
    stick = StickGeometry("cylinder-cone", 0.348, 0.060, 0.0075)
    b = bounce_sequence("pendulum", alpha=0.88, n_flights=12, pivot=0.131, height=0.080,
                        stick=stick)
    times = np.asarray(truth["impact_times_s"])
    # Recorded hits keep the drum's contact law for the timing: 0.8 ms at 1 m/s, scaled as
    # speed^(-1/5); the next flight starts when an impact's contact ends.
    contact = 0.8e-3 * np.ravel(b.impact_tip_speeds) ** -0.2
    delays = np.concatenate(([0.0], np.cumsum(contact[:-1])))
    np.testing.assert_allclose(times - truth["lead_in_s"], np.ravel(b.impacts) + delays,
                               atol=0.5 / fs + 1e-12)
    np.testing.assert_allclose(truth["impact_speeds_m_s"], np.ravel(b.impact_tip_speeds))
    # Nothing before the first impact (no noise); the sound starts on its sample.
    n0 = round(times[0] * fs)
    assert np.all(data[:n0, 0] == 0.0) and data[n0, 0] != 0.0
    hits = truth["recorded_hits"]
    assert hits["files"][0].endswith("avl/38-PearlSnare-1.flac")
    assert not Path(hits["files"][0]).is_absolute()
    assert hits["impact_layers"][0] == 4 and np.all(np.diff(hits["impact_layers"]) <= 0)
    assert len(hits["impact_levels_db"]) == len(times) == 13
    assert truth["measured_room"]["wet_db"] == -14
    assert truth["simulate"]["room"].endswith("genesis6_live_room.flac")
    assert truth["simulate"]["hits"] == hits["files"] and "drum" not in truth["simulate"]


def test_simulate_extra_hits_and_clipping(tmp_path, capsys):
    rel = Path(os.path.relpath(SAMPLES, tmp_path)).as_posix()
    text = _base(tmp_path).replace("wet_db = -14\n", "wet_db = -14\nclip_db = 6\n"
                                   "peak_dbfs = 0\n") + textwrap.dedent(f"""\
        [[simulate.extra_hits]]
        file = "{rel}/avl/37-SideStick-3.flac"
        time_s = -0.35
        [[simulate.extra_hits]]
        file = "{rel}/avl/45-Pearl12Tom-3.flac"
        after_last_s = 0.45
        level_db = -3
        kind = "tom"
        """)
    code, err = _simulate(tmp_path, text, capsys)
    assert code == 0, err
    truth = json.loads((tmp_path / "roll.truth.json").read_text())
    assert truth["spurious_kinds"] == ["37-SideStick-3", "tom"]
    times = truth["impact_times_s"]
    np.testing.assert_allclose(truth["spurious_times_s"],
                               [times[0] - 0.35, times[-1] + 0.45], atol=1 / 22050)
    data, _ = sf.read(tmp_path / "roll.wav")
    assert np.max(np.abs(data)) == 1.0 and truth["clipped_samples"] > 0


def test_simulate_measured_room_with_the_synthetic_drum(tmp_path, capsys):
    text = "\n".join(line for line in _base(tmp_path).splitlines()
                     if not line.startswith("hits ")) + "\n"
    code, err = _simulate(tmp_path, text, capsys)
    assert code == 0, err
    truth = json.loads((tmp_path / "roll.truth.json").read_text())
    assert "recorded_hits" not in truth and truth["measured_room"]["wet_db"] == -14


def _write_bad_files(tmp_path: Path) -> None:
    (tmp_path / "text.flac").write_text("not audio\n")
    sf.write(tmp_path / "silent.wav", np.zeros(4410), 44100)


BAD = {  # name: ((old, new) in the base config, parts of the one-line message)
    "missing sample": (("38-PearlSnare-2.flac", "38-PearlSnare-9.flac"),
                       ["simulate.hits[1]", "no such file", "relative to the config"]),
    "unreadable sample": (('hits = ["', 'hits = ["text.flac", "'),
                          ["simulate.hits[0]", "not a readable audio file"]),
    "silent sample": (('hits = ["', 'hits = ["silent.wav", "'),
                      ["simulate.hits", "silent"]),
    "hits not files": (("hits = [", "hits = [3, "), ["simulate.hits[0]", "file name"]),
    "missing room": (("genesis6_live_room", "no_room"), ["simulate.room", "no such file"]),
    "room file in table": (("room = ", "[simulate.room]\nfile = "),
                           ["simulate.room.file", "string"]),
    "room as number": (('room = "', 'room = 3\n#"'), ["simulate.room", "file name"]),
    "room twice": (("wet_db = -14\n", "wet_db = -14\n[simulate.room]\necho = true\n"),
                   ["invalid TOML"]),
    "wet without room": (("room = ", "#room = "), ["simulate.wet_db", "measured room"]),
    "layer_db without hits": (("hits = ", "layer_db = 6\n#hits = "),
                              ["simulate.layer_db", "only with recorded hits"]),
    "bad layer_db": (("wet_db = -14\n", "wet_db = -14\nlayer_db = 0\n"),
                     ["simulate.layer_db", "(0, 60]"]),
    "bad spread": (("wet_db = -14\n", "wet_db = -14\nlevel_spread_db = -1\n"),
                   ["simulate.level_spread_db"]),
    "drum with hits": (("[simulate.disturbances]", "[simulate.drum]\ndecay_s = 0.2\n"
                        "[simulate.disturbances]"), ["simulate.drum", "recorded hits"]),
    "synthetic spurious": (("snr_db = false", "snr_db = false\nspurious = true"),
                           ["simulate.disturbances.spurious", "extra_hits"]),
    "extra without time": (("wet_db = -14\n", 'wet_db = -14\nextra_hits = [{ file = "x" }]\n'),
                           ["simulate.extra_hits[0].time_s", "exactly one"]),
    "extra without file": (("wet_db = -14\n", "wet_db = -14\nextra_hits = [{ time_s = 1 }]\n"),
                           ["simulate.extra_hits[0].file: missing"]),
    "extra missing file": (("wet_db = -14\n",
                            'wet_db = -14\nextra_hits = [{ file = "nope.flac", time_s = 1 }]\n'),
                           ["simulate.extra_hits[0].file", "no such file"]),
    "bad clip": (("wet_db = -14\n", "wet_db = -14\nclip_db = -3\n"), ["simulate.clip_db"]),
}


@pytest.mark.parametrize("name", BAD)
def test_bad_recorded_configs_exit_2_with_one_line(tmp_path, name, capsys):
    _write_bad_files(tmp_path)
    (old, new), expected = BAD[name]
    text = _base(tmp_path)
    assert old in text
    code, err = _simulate(tmp_path, text.replace(old, new, 1), capsys)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    for part in expected:
        assert part in err
    assert not (tmp_path / "roll.wav").exists()
