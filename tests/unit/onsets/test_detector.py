"""Onset extraction on simulated recordings with known impact times.

Recordings come from :func:`drumroll.simulation.render` (a snare with modes, stick click and
snare wires, in a room, with noise, hum and stray sounds); a tiny home-made synthetic roll is
kept for the cases the simulator does not cover (a hard, low-restitution bouncer) and for
the CLI and I/O tests, which only need some roll.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from drumroll.errors import AudioError, DrumrollError
from drumroll.onsets import COLUMNS, OnsetTable, detect, read_onsets
from drumroll.onsets.candidates import CandidateStream
from drumroll.simulation import Disturbances, Room, render
from paths import DATA


def synthetic_roll(sr: int = 44100, *, t0: float = 0.4, tb: float = 0.25, alpha: float = 0.88,
                   n: int = 30, snr_db: float = 30.0, seed: int = 0, echo: float | None = None,
                   double: float | None = None, click_before: float | None = None,
                   noise_after: float | None = None, tail_s: float = 0.6):
    """A bouncing-stick-like recording: each impact is a few decaying drum modes plus a
    short broadband click with a sub-millisecond rise; white noise sets the SNR relative to
    the first impact's peak. Returns ``samples, sr, true_times, audible`` where ``audible``
    flags impacts whose click peak is 10 dB above the noise RMS."""
    rng = np.random.default_rng(seed)
    flights = tb * alpha ** np.arange(1, n)
    times = t0 + np.concatenate(([0.0], np.cumsum(flights)))
    amps = alpha ** (1.3 * np.arange(times.size))
    N = int((times[-1] + tail_s) * sr)
    x = np.zeros(N)

    def hit(t: float, a: float) -> None:
        n0 = int(np.ceil(t * sr))
        tt = np.arange(min(int(0.3 * sr), N - n0)) / sr + (n0 / sr - t)
        modes = (0.6 * np.exp(-tt / 0.15) * np.sin(2 * np.pi * 187 * tt)
                 + 0.4 * np.exp(-tt / 0.07) * np.sin(2 * np.pi * 311 * tt)
                 + 0.2 * np.exp(-tt / 0.03) * np.sin(2 * np.pi * 523 * tt))
        click = -np.expm1(-tt / 2e-4) * np.exp(-tt / 1.5e-3) * rng.standard_normal(tt.size)
        x[n0:n0 + tt.size] += a * (modes * -np.expm1(-tt / 3e-4) + 0.8 * click)

    for t, a in zip(times, amps, strict=True):
        hit(t, a)
        if echo:
            hit(t + echo, 0.35 * a)
    if double:
        for t, a in zip(times[:4], amps[:4], strict=True):
            hit(t + double, 0.4 * a)
    if click_before:
        hit(times[0] - click_before, 0.5)
    if noise_after:
        hit(times[-1] + noise_after, 0.3)
    noise = 0.8 * 10 ** (-snr_db / 20)
    x += noise * rng.standard_normal(N)
    audible = 0.8 * amps > 3 * noise  # click peak 10 dB over the noise RMS
    scale = 0.5 / np.abs(x).max()
    return x * scale, sr, times, audible


def score(detected: np.ndarray, truth: np.ndarray, audible: np.ndarray, tol: float = 0.002):
    """F1 over audible impacts (a match to an inaudible impact is neither right nor wrong),
    and the offset-free timing error (MAD of detected - true)."""
    d = detected[:, None] - truth[None, :]
    nearest = np.abs(d).argmin(axis=1)
    err = d[np.arange(detected.size), nearest]
    matched = np.abs(err) <= tol
    tp = len(set(nearest[matched]) & set(np.flatnonzero(audible)))
    fp = int(np.count_nonzero(~matched))
    fn = int(np.count_nonzero(audible)) - tp
    f1 = 2 * tp / max(2 * tp + fp + fn, 1)
    e = err[matched]
    mad = float(np.median(np.abs(e - np.median(e)))) if e.size else np.inf
    return f1, mad


def simulated_roll(seed: int, *, snr_db: float = 30.0, sr: int = 44100, room: Room | None = None,
                   spurious: bool = False, hum_hz: float | None = None):
    """A simulated drumroll: restitution 0.8-0.95, first flight 0.15-0.4 s, impacts until the
    flights are 4 ms. Returns the rendering; audible impacts are those with a local SNR of at
    least 0 dB (the benchmark's definition)."""
    rng = np.random.default_rng(seed)
    alpha, tb = rng.uniform(0.8, 0.95), rng.uniform(0.15, 0.4)
    flights = tb * alpha ** np.arange(1, 80)
    times = np.concatenate(([0.0], np.cumsum(flights[flights > 0.004])))
    speeds = rng.uniform(0.8, 1.6) * alpha ** np.arange(times.size)
    return render(times, speeds, sample_rate=sr, room=room or Room(), rng=rng,
                  disturbances=Disturbances(snr_db=snr_db, hum_hz=hum_hz, spurious=spurious))


def detect_and_score(r, **options):
    table = detect(r.samples, r.sample_rate, **options)
    f1, mad = score(table.time_s, r.impact_times_s, r.local_snr_db >= 0)
    return table, f1, mad


ALL = dict(room=Room(echo=True, reverb_time_s=0.4), spurious=True, hum_hz=60.0)


@pytest.mark.parametrize("sr", [22050, 44100, 48000, 96000])
def test_clean_roll_is_found_to_the_sample(sr):
    f1s = []
    for seed in range(3):
        r = simulated_roll(seed, sr=sr)
        table, f1, mad = detect_and_score(r)
        f1s.append(f1)
        assert mad <= 0.25e-3  # goal 0.2 ms: met at 44.1 kHz and up; 0.21 ms at 22.05 kHz
        assert table.time_s[0] >= r.impact_times_s[0] - 0.002  # nothing before the roll
        assert table.time_s[-1] <= r.impact_times_s[-1] + 0.002
        assert np.all(table.sigma_s > 0) and np.all(table.sigma_s < 5e-3)
    # Goal 0.98 (met on average at 30 dB in the benchmark, 0.994); these three rolls score
    # 0.92-1.00 by rate: a roll followed into impacts under its noise (local SNR -8 dB) may
    # time one of them > 2 ms off, which costs 0.05-0.1.
    assert np.mean(f1s) >= 0.9


def test_disturbed_roll_at_20_db():
    f1s = []
    for seed in range(3):
        r = simulated_roll(10 + seed, snr_db=20, **ALL)
        table = detect(r.samples, r.sample_rate, all_candidates=True)
        f1s.append(score(table.time_s, r.impact_times_s, r.local_snr_db >= 0)[0])
        # The tap before the roll and the knock after it are not impacts.
        assert table.time_s[0] >= r.impact_times_s[0] - 0.002
        assert table.time_s[-1] <= r.impact_times_s[-1] + 0.002
    # The goal at 20 dB, met by these three rolls; over the benchmark's 100 rolls at 20 dB the
    # mean is 0.987 on its own seeds and 0.989 on seeds 10-14.
    assert np.mean(f1s) >= 0.98


def test_low_snr_roll():
    f1s = [detect_and_score(simulated_roll(20 + seed, snr_db=12))[1] for seed in range(3)]
    # The goal at 12 dB, met by these three rolls but not in general: the benchmark's mean is
    # 0.972 on its own seeds and 0.918 on seeds 10-14 (rolls with two or three audible
    # impacts are declined, and in short rolls one mistimed faint bounce costs a fifth of the
    # roll's F1).
    assert np.mean(f1s) >= 0.9


def test_stray_sounds_are_rejected_with_reasons():
    r = simulated_roll(31, snr_db=30, spurious=True, hum_hz=50.0)
    table = detect(r.samples, r.sample_rate, all_candidates=True)
    tap, knock = r.spurious_times_s
    assert not np.any(np.abs(table.time_s - tap) < 0.005)
    assert not np.any(np.abs(table.time_s - knock) < 0.005)
    near_tap = np.abs(table.rejected_time_s - tap) < 0.005
    assert near_tap.any() and all(table.rejected_reason[i] == "before the roll"
                                  for i in np.flatnonzero(near_tap))


def test_several_rolls_in_one_file_are_each_reported():
    """A student drops the stick four times in one recording: four rolls, each numbered from
    its own first impact (tails of successive rolls, which can line up into shrinking
    intervals, are not chained into one)."""
    r = simulated_roll(6, snr_db=30)
    x = np.tile(r.samples, 4)
    period = r.samples.shape[0] / r.sample_rate
    table = detect(x, r.sample_rate)
    assert table.rolls == (0, 1, 2, 3)
    for n in table.rolls:
        roll = table.select_roll(n)
        truth = r.impact_times_s + n * period
        assert roll.bounce[0] == 0 and len(roll) >= 8
        np.testing.assert_allclose(roll.time_s, truth[roll.bounce], atol=2e-3)


def test_a_long_recording_of_many_rolls_is_tracked_roll_by_roll(tmp_path, monkeypatch):
    """Twenty rolls 1.5 s apart (64 s): every stretch between two rolls is shorter than the
    longest flight, so the whole file is one stretch of candidates. The tracker chained
    loud impacts of successive rolls into one "roll" (flights that grew, longer than any
    flight considered, 3.2 s apart): the sequence law fitted to it put onsets out of order
    ("bounce 12 after bounce 13") and its audio was read whole, so memory grew with the
    file. Each roll is found on its own, numbered from its first impact, and no excerpt
    read is longer than a roll and its context."""
    import soundfile as sf

    import drumroll.onsets.detector as detector

    r = simulated_roll(6, snr_db=30)
    n = 20
    path = tmp_path / "rolls.wav"
    sf.write(path, np.tile(r.samples, n), r.sample_rate, subtype="PCM_16")
    longest = [0]
    read = detector.read_excerpt

    def recorded(source, start, stop, *args, **kwargs):
        longest[0] = max(longest[0], stop - start)
        return read(source, start, stop, *args, **kwargs)

    monkeypatch.setattr(detector, "read_excerpt", recorded)
    table = detect(path)
    period = r.samples.shape[0] / r.sample_rate
    assert table.rolls == tuple(range(n))
    for k in table.rolls:
        roll = table.select_roll(k)
        assert roll.bounce[0] == 0 and len(roll) >= 8
        np.testing.assert_allclose(roll.time_s, r.impact_times_s[roll.bounce] + k * period,
                                   atol=2e-3)
    assert longest[0] < 8 * r.sample_rate  # the file is 64 s long


def test_targeted_search_recovers_what_the_first_pass_misses():
    # With a file-wide threshold far above the default, only the loud start of the roll is
    # a candidate; the window-by-window search must still follow it into the quiet part,
    # bounce after bounce, numbering on past any bounce it cannot find.
    r = simulated_roll(3, snr_db=30)
    audible = r.local_snr_db >= 0
    strict = detect(r.samples, r.sample_rate, threshold=30.0)
    stream = CandidateStream(r.sample_rate, threshold=30.0)
    stream.feed(r.samples)
    first_pass = stream.finish().time_s
    added = [t for t in strict.time_s if np.min(np.abs(first_pass - t)) > 0.001]
    f1, _ = score(strict.time_s, r.impact_times_s, audible)
    assert f1 >= 0.9
    assert len(added) >= 2
    assert strict.time_s.size >= 0.8 * np.count_nonzero(audible)
    assert_numbered(strict, r.impact_times_s)


def assert_numbered(table, truth: np.ndarray) -> None:
    """Every onset is the true impact its bounce number says (impact 0 is the first): none
    spurious, none numbered one off; an unheard bounce may leave a gap in the numbers.

    Each lies within 5 ms of its impact (far less than any flight here): the numbering is
    what is tested.
    """
    nearest = [int(np.argmin(np.abs(truth - t))) for t in table.time_s]
    assert nearest == table.bounce.tolist(), (nearest, table.bounce.tolist())
    assert np.max(np.abs(truth[nearest] - table.time_s)) < 5e-3


@pytest.mark.parametrize("name", ["table1_d110", "table1_d131", "table2_h50", "tension_hard",
                                  "push"])
def test_bundled_rolls_are_numbered(name):
    """A fit uses the bounce numbers: one numbered one off would shift every later one."""
    root = DATA
    truth = json.loads((root / f"{name}.truth.json").read_text())
    assert_numbered(detect(root / f"{name}.flac"), np.asarray(truth["impact_times_s"]))


def test_bouncing_ball_with_low_restitution():
    x, sr, truth, audible = synthetic_roll(alpha=0.5, tb=0.6, n=9, snr_db=60, seed=2)
    f1, _ = score(detect(x, sr).time_s, truth, audible)
    assert f1 >= 0.9


def test_result_does_not_depend_on_block_size():
    r = simulated_roll(7, snr_db=20)
    a = detect(r.samples, r.sample_rate, block_frames=1000)
    b = detect(r.samples, r.sample_rate, block_frames=1 << 17)
    np.testing.assert_allclose(a.time_s, b.time_s, atol=1e-12)
    np.testing.assert_allclose(a.sigma_s, b.sigma_s, rtol=1e-9)


def test_noise_silence_and_single_hit_are_errors():
    rng = np.random.default_rng(0)
    with pytest.raises(AudioError, match="no drumroll found"):
        detect(0.1 * rng.standard_normal(3 * 44100), 44100)
    with pytest.raises(AudioError, match="silent"):
        detect(np.zeros(44100), 44100)
    r = render([0.0], [1.2], rng=np.random.default_rng(1))
    with pytest.raises(AudioError, match="no drumroll found"):
        detect(r.samples, r.sample_rate)


def _three_unrelated_hits(seed: int, disturbances: Disturbances):
    """A recording with no roll: three hits at random times within 2 s, random speeds."""
    rng = np.random.default_rng(seed)
    times = np.sort(rng.uniform(0.0, 2.0, 3))
    return render(times - times[0], rng.uniform(0.3, 1.5, 3), rng=rng,
                  disturbances=disturbances)


def test_a_pattern_in_the_ring_down_is_not_a_roll():
    """Three unrelated hits; 0.76 s after the last, four faint wiggles of its ring-down and
    the noise are spaced like bounces, but each is quieter than the sound it lands in."""
    r = _three_unrelated_hits(2000, Disturbances(snr_db=20))
    with pytest.raises(AudioError, match="no drumroll found"):
        detect(r.samples, r.sample_rate)


def test_a_faint_tap_does_not_start_the_roll():
    """Three unrelated hits and, 1 s before them, a tap quieter than the hum and noise it
    lands in: the tap used to be taken as the first bounce of a four-bounce roll. A bouncer
    starts with its loudest impact, so the roll may not start with an onset that does not
    stand out, and three hits are not a roll."""
    r = _three_unrelated_hits(7919 + 12000 + 4,
                              Disturbances(snr_db=12, hum_hz=50.0, spurious=True))
    with pytest.raises(AudioError, match="only 3 impacts"):
        detect(r.samples, r.sample_rate)


@pytest.mark.slow
def test_sigma_s_matches_the_timing_errors():
    """(detected - true) / sigma_s should scatter with a spread of about one."""
    err, sig = [], []
    for snr, cond in ((30, {}), (20, {}), (20, ALL), (30, ALL)):
        for seed in range(3):
            r = simulated_roll(100 + 10 * snr + seed, snr_db=snr, **cond)
            table = detect(r.samples, r.sample_rate)
            d = table.time_s[:, None] - r.impact_times_s[None, :]
            e = d[np.arange(d.shape[0]), np.abs(d).argmin(axis=1)]
            ok = np.abs(e) < 0.005
            err.extend(e[ok] - np.median(e[ok]))  # the start time is fitted anyway
            sig.extend(table.sigma_s[ok])
    z = np.asarray(err) / np.asarray(sig)
    spread = 1.4826 * np.median(np.abs(z - np.median(z)))
    assert 0.6 <= spread <= 1.6
    assert np.mean(np.abs(z) < 3) >= 0.8


def test_unknown_option_is_a_type_error():
    with pytest.raises(TypeError, match="bogus"):
        detect(np.zeros(10), 44100, bogus=1)


# -- table I/O -------------------------------------------------------------------------------
def _table():
    return OnsetTable(np.array([0.5, 0.72, 0.91]), np.array([0.3, 0.2, 0.1]),
                      np.array([30.0, 25.0, 20.0]), np.array([1e-5, 2e-5, 4e-5]))


def test_csv_roundtrip(tmp_path):
    p = tmp_path / "o.csv"
    p.write_text(_table().to_csv())
    assert p.read_text().splitlines()[0] == ",".join(COLUMNS)
    back = read_onsets(p)
    np.testing.assert_allclose(back.time_s, _table().time_s)
    np.testing.assert_allclose(back.sigma_s, _table().sigma_s)
    np.testing.assert_allclose(back.interval_s[1:], np.diff(_table().time_s))


def test_labels_and_plain_text(tmp_path):
    lab = tmp_path / "l.txt"
    lab.write_text(_table().to_labels())
    plain = tmp_path / "p.txt"
    plain.write_text(_table().to_text())
    for p in (lab, plain):
        t = read_onsets(p)
        np.testing.assert_allclose(t.time_s, _table().time_s, atol=1e-6)
        assert np.all(np.isnan(t.amplitude))
    # The labels keep each onset's timing error (to 0.1 µs); plain times have none.
    np.testing.assert_allclose(read_onsets(lab).sigma_s, _table().sigma_s, atol=1e-10)
    assert np.all(read_onsets(plain).sigma_s == 0)


@pytest.mark.parametrize("text, where", [
    ("time_s,sigma_s\n0.1,0\n0.2\n", "line 3"),
    ("0.1\nabc\n", "line 2"),
    ("0.1\t0.1\thit\nx\t0.2\thit\n", "line 2"),
    ("0.1 0.2\n", "line 1"),
])
def test_malformed_onset_files_name_the_line(tmp_path, text, where):
    p = tmp_path / "bad.txt"
    p.write_text(text)
    with pytest.raises(DrumrollError, match=where):
        read_onsets(p)


def test_sequence_law_ignores_a_mistimed_onset():
    from drumroll.onsets.sequence import fit_sequence

    times = 0.3 + np.concatenate(([0.0], np.cumsum(0.2 * 0.88 ** np.arange(1, 16))))
    measured = times + 1e-4 * np.random.default_rng(0).standard_normal(times.size)
    measured[12] += 4e-3  # a faint bounce found where its sound grows, not where it starts
    law = fit_sequence(measured, np.full(times.size, 1e-4))
    assert abs(law.time_s[12] - times[12]) < 3e-4
    assert np.all(law.sd_s < 5e-4)
    assert fit_sequence(measured[:4], np.full(4, 1e-4)) is None  # too few to fit a law


def test_prior_decides_only_where_the_waveform_does_not():
    from drumroll.onsets.refine import Prior, aic_onset

    rng = np.random.default_rng(1)
    sharp = np.concatenate((rng.standard_normal(400), 10 * rng.standard_normal(400)))
    prior = Prior(mean=300.0, sd=5.0, outlier=0.05, width=400)
    assert abs(aic_onset(sharp, 200, 600, prior=prior)[0] - 400) <= 2  # likelihood wins
    faint = np.concatenate((rng.standard_normal(400), 1.1 * rng.standard_normal(400)))
    k, spread = aic_onset(faint, 200, 600, prior=prior)
    assert abs(k - 300) <= 15  # no clear start: the prior places it
    assert spread < aic_onset(faint, 200, 600)[1]


def test_envelope_places_a_faint_impact_at_its_start_not_its_growth():
    """A sound whose first 4 ms are 12 dB under its peak (a snare's wires slap a head period
    in), once loud and once 9 dB under the background: the waveform's step is where the faint
    one grows; the loud one's envelope, as a template, puts it where it starts."""
    from drumroll.onsets.envelope import STRONG, profile

    shape = np.concatenate((np.full(16, 10 ** -1.2), np.exp(-np.arange(120) / 40.0)))
    n, loud_at, faint_at = 400, 20, 260
    mean = 1.0 + 300.0 * _shifted(shape, n, loud_at) + 0.9 * _shifted(shape, n, faint_at)
    trials = np.arange(faint_at - 24, faint_at + 24)
    errors, at_growth = [], []
    for seed in range(20):
        # A bin's power scatters about its mean (8 degrees of freedom here).
        power = mean * np.random.default_rng(seed).gamma(8.0, 1.0 / 8.0, n)
        ll = profile(power[200:], shape, np.array([loud_at - 200]), trials - 200)
        errors.append(int(trials[np.argmax(ll)]) - faint_at)
        at_growth.append(ll[trials == faint_at + 16][0])
    errors = np.abs(errors)
    assert np.median(errors) <= 1 and np.mean(errors <= 3) >= 0.9  # bins of the envelope
    assert max(at_growth) < -STRONG  # the change point's place is ruled out every time


@pytest.mark.slow
def test_faint_bounces_are_not_timed_where_their_sound_grows():
    """In the simulator a snare's wires slap a head period (5 ms) after the stick lands, so
    a faint bounce's sound grows well after it starts. Without the envelope 4 of these 20
    rolls' 189 onsets came more than 2 ms late (F1 0.955); with it, 2 (F1 0.963)."""
    late, f1s = 0, []
    for seed in range(100, 120):
        r = simulated_roll(seed, snr_db=12)
        table, f1, _ = detect_and_score(r)
        f1s.append(f1)
        d = table.time_s[:, None] - r.impact_times_s[None, :]
        late += int(np.sum(d[np.arange(d.shape[0]), np.abs(d).argmin(axis=1)] > 0.002))
    assert late <= 2
    assert np.mean(f1s) >= 0.96


def test_a_short_roll_is_completed_by_the_whole_sound_of_its_fourth_bounce():
    """Two audible impacts and two fainter ones: the waveform search finds three onsets, and
    three (one flight ratio, nothing to test it with) are no roll. The fourth bounce's whole
    sound, where the flight law puts it, completes it (these were declined before)."""
    for seed, options in ((12011, {}), (12013, dict(sr=22050, spurious=True, hum_hz=50.0))):
        r = simulated_roll(seed, snr_db=12, **options)
        assert np.count_nonzero(r.local_snr_db >= 0) == 2
        table = detect(r.samples, r.sample_rate)
        assert table.time_s.size == 4
        np.testing.assert_allclose(table.time_s, r.impact_times_s[:4], atol=1.5e-3)


def test_the_envelope_tells_a_faint_bounce_from_none():
    """The Bayes factor "a bounce (amplitude up to the last one's) somewhere in the window"
    against "none": strong for most bounces 9 dB under the background (16 of these 20),
    and (0 of 20) where there is none."""
    from drumroll.onsets.envelope import STRONG, profile

    shape = np.concatenate((np.full(16, 10 ** -1.2), np.exp(-np.arange(120) / 40.0)))
    n, loud_at, faint_at = 400, 20, 260
    trials = np.arange(faint_at - 24, faint_at + 24)
    strong = []
    for with_bounce in (True, False):
        mean = 1.0 + 300.0 * _shifted(shape, n, loud_at)
        if with_bounce:
            mean += 0.9 * _shifted(shape, n, faint_at)
        found = 0
        for seed in range(20):
            power = mean * np.random.default_rng(seed).gamma(8.0, 1.0 / 8.0, n)
            log_bf = profile(power[200:], shape, np.array([loud_at - 200]), trials - 200,
                             against_none=300.0)
            found += np.log(np.mean(np.exp(log_bf))) >= STRONG
        strong.append(found)
    assert strong[0] >= 14 and strong[1] <= 1


def _shifted(shape: np.ndarray, n: int, at: int) -> np.ndarray:
    out = np.zeros(n)
    out[at: at + shape.size] = shape[: n - at]
    return out


def benchmark_roll(snr_db: float, sr: int, seed: int):
    """The roll ``benchmarks/onsets.py`` renders for this SNR and seed in its "clean"
    condition: :func:`simulated_roll` with the benchmark's seed."""
    return simulated_roll(int(1000 * snr_db) + seed, snr_db=snr_db, sr=sr)


def test_faint_onsets_do_not_widen_the_laws_prior():
    """Onsets that cannot be timed to the sample (quieter than what they land in) report a
    wide sigma_s; the law's scatter was floored at the median sigma_s of every onset, so the
    more of them a roll reported, the wider every onset's prior became. The floor is the
    typical sigma_s of the onsets whose start can be told."""
    from drumroll.onsets.sequence import fit_sequence

    times = 0.3 + np.concatenate(([0.0], np.cumsum(0.2 * 0.88 ** np.arange(1, 16))))
    measured = times + 1e-4 * np.random.default_rng(0).standard_normal(times.size)
    sigmas = np.full(times.size, 1e-4)
    sigmas[8:] = 1e-3  # eight faint late bounces, each timed to a millisecond
    timeable = sigmas < 5e-4
    assert np.all(fit_sequence(measured, sigmas).sd_s > 7e-4)
    assert np.all(fit_sequence(measured, sigmas, timeable=timeable).sd_s[:8] < 2e-4)


def test_a_faint_bounce_is_not_moved_to_a_far_step_by_a_wide_prior():
    """The benchmark's 20 dB, 48 kHz clean roll of seed 0: its faint bounce 5 lands in the
    ring of the bounces before, where a stronger step comes 3 ms before it. With a prior as
    wide as the median sigma_s of the roll's four faint late onsets (0.5 ms), the law's
    retiming took that step (3.3 ms early: a false onset and a missed bounce); with the
    prior of the onsets that can be timed it stays within 1.2 ms, in tolerance."""
    r = benchmark_roll(20.0, 48000, 0)
    table = detect(r.samples, r.sample_rate)
    np.testing.assert_array_equal(table.bounce[:8], np.arange(8))
    err = table.time_s - r.impact_times_s[table.bounce]
    assert abs(err[5] - np.median(err)) < 1.5e-3


@pytest.mark.parametrize(("found", "sd", "lag"), [
    # the corpus's pearl2 at 48 kHz: its first 0.5 ms under the next bounces' ring
    ([24, 24, 24, 24], [4.0, 6.7, 6.6, 3.2], 24.0),
    ([58, 59, 59, 56], [4.7, 3.9, 3.8, 5.4], 58.0),  # the corpus's hard release, 96 kHz
    ([-2, -2, -2, -4], [1.7, 1.7, 1.7, 3.7], -2.0),  # the corpus's stereo porkpie
    ([-2, -2, -3, -1], [1.0, 3.8, 4.0, 3.5], -2.0),  # the corpus's pearl: sds too wide
    ([51], [2.4], 51.0),  # one sharp alignment (a real porkpie hit, 48 kHz)
    ([0, 0, 0, 0], [1.5, 1.6, 1.6, 1.8], 0.0),
])
def test_ring_alignments_that_agree_move_the_first_impact(found, sd, lag):
    """Alignments that agree within their precision (or more closely than their stated sds
    say: how well they agree tells) move the first impact by the lag they show."""
    from drumroll.onsets.start import ring_lag

    shift, err = ring_lag(np.array(found), np.array(sd), -44, 352)
    assert abs(shift - lag) < 0.75 and err < 8.0


@pytest.mark.parametrize(("found", "sd"), [
    # the simulator at 20 dB: a bounce's own sound is not quite the first impact's
    ([13, -9, -4, -16], [6.7, 7.4, 5.1, 4.6]),
    ([-4, -4, 2, -15], [9.9, 7.6, 9.1, 14.7]),
    ([7, -5, 1, -12], [3.1, 8.8, 8.3, 6.7]),  # the corpus's soft, noisy porkpie
    ([-4, 59, 1, 2], [107.6, 116.5, 1.8, 3.3]),  # the corpus's sonic: two fits that say little
    ([-15], [42.6]),  # one alignment as imprecise as it is far from nil
])
def test_ring_alignments_that_disagree_leave_the_first_impact(found, sd):
    """Alignments that disagree, or are as imprecise as they are far from nil, are no
    evidence of a lag: the median of the alignments moved the first onset by their noise
    (0.1-0.3 ms on the simulator), where the change point had already put it at the same
    point of its sound as the next ones."""
    from drumroll.onsets.start import ring_lag

    shift, err = ring_lag(np.array(found), np.array(sd), -44, 352)
    assert shift == 0.0
    assert err > 0.25  # and the first onset's sigma_s says how unsure that is


def test_the_first_impact_is_not_moved_by_disagreeing_ring_alignments():
    """The benchmark's 20 dB, 22.05 kHz clean roll of seed 3: the next bounces' alignments of
    the first impact were [13, -9, -4, -16] samples, and their median moved its onset 0.28 ms
    ahead of the same point of the next bounces' sounds. They disagree as much as they
    differ from nil, so it stays where its change point put it (0.01 ms from them)."""
    r = benchmark_roll(20.0, 22050, 3)
    table = detect(r.samples, r.sample_rate)
    err = table.time_s - r.impact_times_s[table.bounce]
    np.testing.assert_array_equal(table.bounce[:6], np.arange(6))
    assert abs(err[0] - np.median(err[1:6])) < 0.1e-3


@pytest.mark.parametrize("seed", range(5))
def test_a_long_pre_echo_is_not_taken_for_the_sound_it_precedes(seed):
    """A codec's noise 3 ms ahead of an impact (Opus's short windows reach 5 ms), 20 dB above
    the background and 30 dB under the impact: the impact's sound rises out of noise that far
    under it within IMPACT_RISE_S of its start, so its start is looked for there and not over
    the whole stretch (whose middle is 1.5 ms early); a stretch shorter than that, which may
    be the impact's own first stage, still places it in its middle."""
    from drumroll.onsets.refine import IMPACT_RISE_S, refine_onset

    sr, start = 48000, 1000
    rng = np.random.default_rng(seed)
    rise = round(IMPACT_RISE_S * sr)
    for ahead in (round(0.003 * sr), round(0.0015 * sr)):
        y = np.concatenate((rng.standard_normal(start - ahead),
                            10.0 * rng.standard_normal(ahead),
                            300.0 * rng.standard_normal(400)))
        r = refine_onset(y, start, sr, pre=480, post=96, search=ahead + 48, search_after=96,
                         codec_block=240)
        hidden = min(ahead, rise)
        assert abs(r.sample - (start - hidden / 2)) <= 4, (ahead, r.sample - start)
        # The uncertainty is that of a start anywhere over where the sound can hide.
        assert r.sigma_s >= 0.9 * hidden / np.sqrt(12.0) / sr
        assert r.sigma_s < 1.2 * hidden / np.sqrt(12.0) / sr + 2 / sr


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_refine_within_places_the_onset_only_where_it_is_allowed(seed):
    """A sound 20 ms before an impact (a tap, the ring of the bounce before) is the first
    step of a wide search, and the split lands on it; narrowed to the impact's surroundings
    (``within``: the flight-law stage bounds its moves so), the onset is the impact's start,
    with the same window and whitening."""
    from drumroll.onsets.refine import refine_onset

    sr, start = 48000, 3000
    rng = np.random.default_rng(seed)
    tap = start - round(0.02 * sr)
    y = rng.standard_normal(start + 600)
    y[tap:start] += 60.0 * rng.standard_normal(start - tap) * np.exp(-np.arange(start - tap) / 400)
    y[start:start + 600] += 200.0 * rng.standard_normal(600) * np.exp(-np.arange(600) / 300)
    wide = refine_onset(y, start, sr, pre=1500, post=96, search=1200, search_after=96)
    assert abs(wide.sample - tap) <= 4
    narrowed = refine_onset(y, start, sr, pre=1500, post=96, search=1200, search_after=96,
                            within=(start - 96, start + 96))
    assert abs(narrowed.sample - start) <= 4
    assert narrowed.sigma_s < 0.1e-3


@pytest.mark.parametrize("draw", [pytest.param(16, id="tap 34.5 ms ahead"),
                                  pytest.param(70, id="tap 16.5 ms ahead")])
def test_a_sound_before_the_first_impact_does_not_take_its_onset(draw):
    """Recordings ``calibrate --audio`` renders (table2_h80's priors: a jitter of 4 and 2.5
    ms, a tap before the roll): the first impact, the roll's loudest, was found where it is,
    and the flight-law stage, whose search a scatter of milliseconds widens, then moved it
    back onto the tap before it (the ids say how far). A move that far onto a fainter sound is
    refused now (``LOUD_STAGE_S``): the first onset stays the first impact's."""
    import io

    import soundfile as sf

    from drumroll.calibration.recording import Recorder
    from drumroll.calibration.roll import RollSimulator
    from drumroll.calibration.run import draw_seeds
    from drumroll.config import load_config
    from drumroll.onsets import detect
    from drumroll.pipeline import choose_roll
    from drumroll.simulation.simulate import render_roll

    config = load_config(DATA / "table2_h80.toml")
    roll_rng, sound_rng, _, _ = draw_seeds(0, draw)
    roll = RollSimulator(config, config.model, 16).draw(roll_rng)
    recorder = Recorder(config)
    rendering = render_roll(recorder.settings, recorder.sources, roll.times - roll.t0,
                            roll.speeds, sound_rng)
    buffer = io.BytesIO()  # as calibrate hears it: a 16-bit WAV
    sf.write(buffer, rendering.samples, rendering.sample_rate, subtype="PCM_16", format="WAV")
    buffer.seek(0)
    samples, rate = sf.read(buffer, dtype="float64")
    first = choose_roll(detect(samples, rate)).onsets.time_s[0]
    impacts = rendering.impact_times_s
    assert abs(first - impacts[0]) < 0.5e-3, (first - impacts[0]) * 1e3
