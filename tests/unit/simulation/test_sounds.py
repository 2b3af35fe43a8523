"""Tests of the drumroll sound engine: impacts, room, disturbances, mixing and truth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from drumroll.simulation import Disturbances, DrumSound, Room, render
from drumroll.simulation.render import LOCAL_SNR_HIGHPASS_HZ, LOCAL_SNR_WINDOW_S
from drumroll.simulation.sounds import ImpactSynth, membrane_modes

FS = 44100
QUIET = Disturbances(snr_db=None, lead_in_s=0.1, tail_s=0.3)
STEADY = DrumSound(hit_variation_db=0.0, strike_jitter=0.0)


def _roll(n: int = 20, alpha: float = 0.87, t_b: float = 0.25, v0: float = 1.5):
    times = np.concatenate([[0.0], np.cumsum(t_b * alpha ** np.arange(n - 1))])
    return times, v0 * alpha ** np.arange(n)


def _rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def test_membrane_ratios_are_bessel_zero_ratios():
    ratios, orders = membrane_modes(10)
    expected = [1, 1.594, 2.136, 2.296, 2.653, 2.918, 3.156, 3.501, 3.600, 3.647]
    np.testing.assert_allclose(ratios, expected, atol=2e-3)
    assert list(orders[:4]) == [0, 1, 2, 0]


@pytest.mark.parametrize("room", [Room(), Room(echo=True, reverb_time_s=0.3)])
@pytest.mark.parametrize("frac", [0.0, 0.37, 0.999])
def test_sound_starts_exactly_at_the_impact(room, frac):
    onset_in = 0.1 + frac / FS
    r = render([frac / FS, 0.2], [1.0, 0.8], sample_rate=FS, room=room, disturbances=QUIET,
               rng=_rng())
    assert r.impact_times_s[0] == pytest.approx(onset_in, abs=1e-12)
    n0 = int(np.ceil(r.impact_times_s[0] * FS))
    assert np.all(r.samples[:n0] == 0.0)
    assert np.max(np.abs(r.samples[n0:n0 + 5])) > 0
    # The second impact's first sample is where the sound changes, not before.
    n1 = int(np.ceil(r.impact_times_s[1] * FS))
    alone = render([frac / FS], [1.0], sample_rate=FS, room=room, disturbances=QUIET,
                   rng=_rng())
    m = min(len(alone.samples), n1)
    np.testing.assert_allclose(r.samples[:m] / r.scale, alone.samples[:m] / alone.scale,
                               atol=1e-12)


def test_contact_response_matches_numerical_convolution():
    drum = DrumSound(n_modes=1, click_level=0, snare_level=0, pitch_glide=0,
                     hit_variation_db=0, strike_jitter=0, stick_modes_hz=())
    synth = ImpactSynth(drum, FS)
    voice = synth.voices(np.array([1.0]), _rng())[0]
    onset, n = 0.01 + 0.37 / FS, 1500
    out, zeros = np.zeros(n), np.zeros(n)
    synth.add_hit(out, 0, voice, onset, zeros, zeros)
    up = 200  # brute force on a 200x finer grid
    tt = np.arange(n * up) / (FS * up)
    tc, s = voice.contact_s, synth._s[0]
    force = np.where((tt >= onset) & (tt < onset + tc),
                     np.pi / (2 * tc) * np.sin(np.pi * (tt - onset) / tc), 0.0)
    h = np.exp(s * np.arange(int(0.06 * FS * up)) / (FS * up)).imag
    y = signal.fftconvolve(force, h)[:len(tt)] / (FS * up)
    np.testing.assert_allclose(out, voice.mode_amps[0] * y[::up], atol=1e-4)


def test_modal_peaks_at_membrane_ratios():
    drum = DrumSound(fundamental_hz=180.0, decay_s=0.6, click_level=0, snare_level=0,
                     mode_split=0.0, pitch_glide=0.0, hit_variation_db=0, strike_jitter=0)
    r = render([0.0], [1.0], sample_rate=FS, drum=drum, disturbances=QUIET, rng=_rng())
    n0 = int(np.ceil(r.impact_times_s[0] * FS))
    x = r.samples[n0:n0 + FS]
    x = np.pad(x, (0, FS - len(x)))
    spec = np.abs(np.fft.rfft(x * np.hanning(FS), 8 * FS))
    f = np.fft.rfftfreq(8 * FS, 1 / FS)
    ratios, _ = membrane_modes(drum.n_modes)
    for ratio in ratios[:6]:
        target = 180.0 * ratio
        band = (f > target * 0.97) & (f < target * 1.03)
        f_peak = f[band][np.argmax(spec[band])]
        assert f_peak == pytest.approx(target, rel=2e-3)


def test_louder_and_brighter_for_faster_impacts():
    synth = ImpactSynth(STEADY, FS)
    slow, fast = synth.voices(np.array([0.5, 1.0]), _rng())
    assert fast.contact_s < slow.contact_s
    # Fundamental amplitude follows the loudness exponent; higher modes gain more.
    ratio = fast.mode_amps / slow.mode_amps
    assert ratio[0] == pytest.approx(2**STEADY.loudness_exponent, rel=1e-9)
    assert np.all(ratio[1:] > ratio[0])
    assert fast.snare_amp > slow.snare_amp and fast.click_amp > slow.click_amp
    powers = []
    for v in (0.25, 0.5, 1.0, 2.0):
        r = render([0.0], [v], sample_rate=FS, drum=STEADY, disturbances=QUIET, rng=_rng())
        powers.append(r.reference_power)
    assert np.all(np.diff(powers) > 0)


def test_echo_at_the_drawn_delay():
    dist = Disturbances(snr_db=None, lead_in_s=0.1, tail_s=0.2)
    wet = render([0.0], [1.0], sample_rate=FS, room=Room(echo=True, echo_gain=0.5),
                 disturbances=dist, rng=_rng(4))
    dry = render([0.0], [1.0], sample_rate=FS, room=Room(), disturbances=dist, rng=_rng(4))
    delay = wet.echo_delay_s[0]
    assert 0.005 <= delay <= 0.015
    direct = dry.samples / dry.scale
    echo = wet.samples / wet.scale - direct
    xc = signal.correlate(echo, direct, mode="full")
    lag = (np.argmax(xc) - (len(direct) - 1)) / FS
    assert lag == pytest.approx(delay, abs=1.5 / FS)
    # Its level: half the direct sound's, a little less for the reflection's low-pass.
    assert 0.3 < np.max(xc) / np.sum(direct**2) < 0.55


def test_reverb_tail_has_requested_decay():
    dist = Disturbances(snr_db=None, lead_in_s=0.1, tail_s=2.0)
    room = Room(reverb_time_s=0.8, direct_to_reverb_db=0.0)
    drum = DrumSound(decay_s=0.02, snare_decay_s=0.01, click_level=0.0)
    wet = render([0.0], [1.0], drum=drum, room=room, disturbances=dist, rng=_rng(2))
    dry = render([0.0], [1.0], drum=drum, disturbances=dist, rng=_rng(2))
    tail = wet.samples / wet.scale - dry.samples / dry.scale
    sos = signal.butter(4, 400, "lowpass", fs=FS, output="sos")
    env = signal.sosfilt(sos, tail) ** 2
    n0 = int(wet.impact_times_s[0] * FS)
    level = [10 * np.log10(np.mean(env[n0 + int(a * FS):n0 + int((a + 0.1) * FS)]))
             for a in (0.3, 0.7)]
    decay_rate = (level[0] - level[1]) / 0.4  # dB/s; RT60 0.8 s is 75 dB/s
    assert decay_rate == pytest.approx(60 / 0.8, rel=0.2)


@pytest.mark.parametrize("snr_db", [10.0, 30.0, 50.0])
def test_noise_snr_matches_request(snr_db):
    dist = Disturbances(snr_db=snr_db, noise_fluctuation_db=0.0, lead_in_s=1.0, tail_s=0.2)
    r = render(*_roll(5), sample_rate=FS, disturbances=dist, rng=_rng(1))
    clean = render(*_roll(5), sample_rate=FS, disturbances=Disturbances(
        snr_db=None, lead_in_s=1.0, tail_s=0.2), rng=_rng(1))
    # The reference power is the loudest impact's own 10 ms window (no other hit in it).
    n0 = int(np.ceil(clean.impact_times_s[0] * FS))
    p_ref = np.mean((clean.samples[n0:n0 + round(0.01 * FS)] / clean.scale) ** 2)
    assert p_ref == pytest.approx(clean.reference_power, rel=1e-9)
    noise = r.samples[:int(0.95 * FS)] / r.scale
    measured = 10 * np.log10(r.reference_power / np.mean(noise**2))
    assert measured == pytest.approx(snr_db, abs=1.0)


def test_noise_is_pinkish():
    dist = Disturbances(snr_db=20.0, lead_in_s=3.0, tail_s=0.1)
    r = render([0.0], [1.0], disturbances=dist, rng=_rng(5))
    f, p = signal.welch(r.samples[:int(2.9 * FS)], fs=FS, nperseg=4096)
    low = np.mean(p[(f > 200) & (f < 400)])
    high = np.mean(p[(f > 1600) & (f < 3200)])
    assert 10 * np.log10(low / high) == pytest.approx(9.0, abs=3.0)  # -3 dB per octave


def test_hum_level_and_frequency():
    dist = Disturbances(snr_db=None, hum_hz=60.0, hum_db=-20.0, lead_in_s=2.0, tail_s=0.1)
    r = render([0.0], [1.0], disturbances=dist, rng=_rng(6))
    hum = r.samples[:int(1.9 * FS)] / r.scale
    assert 10 * np.log10(np.mean(hum**2) / r.reference_power) == pytest.approx(-20.0, abs=0.5)
    f, p = signal.welch(hum, fs=FS, nperseg=FS)
    assert f[np.argmax(p)] == pytest.approx(60.0, abs=1.0)


def test_local_snr_falls_for_later_softer_hits():
    r = render(*_roll(25), room=Room(echo=True, reverb_time_s=0.3),
               disturbances=Disturbances(snr_db=35.0), rng=_rng(7))
    snr = r.local_snr_db
    assert snr.shape == (25,)
    assert np.polyfit(np.arange(25), snr, 1)[0] < -1.0
    assert snr[-1] < snr[0] - 30
    assert np.all(np.diff(snr[::5]) < 0)


def test_local_snr_is_exact_for_two_hits():
    drum = DrumSound()
    times, speeds = np.array([0.0, 0.2]), np.array([1.2, 1.0])
    r = render(times, speeds, drum=drum, disturbances=QUIET, rng=_rng(8))
    only_first = render(times[:1], speeds[:1], drum=drum, disturbances=QUIET, rng=_rng(8))
    sos = signal.butter(4, LOCAL_SNR_HIGHPASS_HZ, "highpass", fs=FS, output="sos")
    mix = signal.sosfilt(sos, r.samples / r.scale)
    first = signal.sosfilt(sos, only_first.samples / only_first.scale)
    n1, w = int(np.ceil(r.impact_times_s[1] * FS)), round(LOCAL_SNR_WINDOW_S * FS)
    other = first[n1:n1 + w]
    own = mix[n1:n1 + w] - other
    expected = 10 * np.log10(np.sum(own**2) / np.sum(other**2))
    assert r.local_snr_db[1] == pytest.approx(expected, abs=0.05)
    assert r.local_snr_db[0] == 200.0  # nothing else sounds before the first hit


def test_deterministic_for_a_seed():
    kwargs = dict(room=Room(echo=True, reverb_time_s=0.2),
                  disturbances=Disturbances(hum_hz=50.0, spurious=True), channels=2)
    a = render(*_roll(8), rng=_rng(11), **kwargs)
    b = render(*_roll(8), rng=_rng(11), **kwargs)
    c = render(*_roll(8), rng=_rng(12), **kwargs)
    np.testing.assert_array_equal(a.samples, b.samples)
    assert a.truth() == b.truth()
    assert not np.array_equal(a.samples, c.samples)


def test_channels_differ_slightly_and_never_clip():
    r = render(*_roll(6), channels=2, disturbances=Disturbances(snr_db=30.0), rng=_rng(13))
    assert r.samples.shape[1] == 2
    assert np.max(np.abs(r.samples)) == pytest.approx(10 ** (-1 / 20))
    assert r.channel_delays_s[0] == 0.0 and 0 < r.channel_delays_s[1] <= 0.5e-3
    lead = r.samples[:int(0.4 * FS)]
    assert abs(np.corrcoef(lead[:, 0], lead[:, 1])[0, 1]) < 0.1  # independent noise
    n0 = int(np.ceil(r.impact_times_s[0] * FS))
    body = r.samples[n0:n0 + int(0.2 * FS)]
    assert np.corrcoef(body[:, 0], body[:, 1])[0, 1] > 0.5  # same drum


def test_spurious_events_are_reported_and_placed():
    times, speeds = _roll(10)
    r = render(times, speeds, disturbances=Disturbances(spurious=True, lead_in_s=0.1),
               rng=_rng(14))
    assert r.spurious_kinds == ("tap", "knock")
    tap, knock = r.spurious_times_s
    assert 0.2 <= r.impact_times_s[0] - tap <= 1.0
    assert tap >= 0.2 - 1e-12  # the lead-in grew to fit it
    assert knock > r.impact_times_s[-1] + 0.3
    assert r.duration_s > knock + 0.4
    n = int(np.ceil(tap * FS))
    assert np.max(np.abs(r.samples[n:n + 200])) > 5 * np.max(np.abs(r.samples[n - 400:n - 200]))


def test_truth_is_json_ready():
    import json

    r = render(*_roll(4), disturbances=Disturbances(spurious=True), rng=_rng(15))
    truth = json.loads(json.dumps(r.truth()))
    assert len(truth["impact_times_s"]) == 4 and len(truth["local_snr_db"]) == 4
    assert truth["frames"] == len(r.samples)


@pytest.mark.parametrize("fs", [22050, 96000])
def test_other_sample_rates(fs):
    r = render(*_roll(5), sample_rate=fs, room=Room(echo=True, reverb_time_s=0.2),
               rng=_rng(16))
    assert r.sample_rate == fs and np.all(np.isfinite(r.samples))
    n0 = int(np.ceil(r.impact_times_s[0] * fs))
    assert np.max(np.abs(r.samples[n0:n0 + int(0.01 * fs)])) > 0.1


@pytest.mark.parametrize("kwargs", [
    dict(drum=None), dict(times=[0.0, -1.0]), dict(speeds=[1.0, 0.0]), dict(channels=0),
    dict(sample_rate=1000),
])
def test_bad_inputs_raise(kwargs):
    times = kwargs.pop("times", [0.0, 0.1])
    speeds = kwargs.pop("speeds", [1.0, 0.9])
    if kwargs.get("drum", 1) is None:
        with pytest.raises(ValueError, match="decay_s"):
            DrumSound(decay_s=0.0)
        with pytest.raises(ValueError, match="reverb_time_s"):
            Room(reverb_time_s=-1.0)
        with pytest.raises(ValueError, match="snr_db"):
            Disturbances(snr_db=500.0)
        return
    with pytest.raises(ValueError):
        render(times, speeds, rng=_rng(), **kwargs)
