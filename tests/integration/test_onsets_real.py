"""The onset extractor on real sounds: the bundled real ping-pong recording, and drumrolls
rendered from real recorded snare hits in measured rooms (data/samples), each test a case
that the extractor's earlier rules got wrong.

Each roll's impact times come from the exact pendulum (the paper's stick) and its sound from
real hits, layered by impact speed: a sound the extractor was not developed on.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import soundfile as sf

from drumroll.onsets import OnsetTable, detect
from drumroll.physics import StickGeometry, bounce_sequence
from drumroll.simulation import Disturbances
from drumroll.simulation.hits import HitBank
from drumroll.simulation.measured_room import MeasuredRoom
from drumroll.simulation.render_hits import ExtraHit, render_hits
from paths import CORPUS, DATA

SAMPLES = DATA / "samples"
SNARES = {
    "pearl": [f"avl/38-PearlSnare-{i}.flac" for i in range(1, 6)],
    "pearl2": [f"avl/38-PearlSnare2-{i}.flac" for i in range(1, 6)],
    "porkpie": [f"avl/38-PorkpieSnare-{i}.flac" for i in range(1, 6)],
}
ROOMS = {"live": "rooms/genesis6_live_room.flac",
         "hall": "rooms/arthur_sykes_rymer_auditorium.flac"}
STICK = StickGeometry("cylinder-cone", length=0.348, tip=0.060, radius=0.0075)


def pendulum_roll(alpha: float = 0.88, release: float = 0.0, n: int = 30
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Impact times (from the first) and tip speeds of the exact pendulum, d = 131 mm,
    h = 80 mm, released at ``release`` m/s; impacts slower than 0.05 m/s are left out."""
    b = bounce_sequence("pendulum", alpha=alpha, n_flights=n, pivot=0.131, height=0.080,
                        release_speed=release, stick=STICK)
    times, speeds = np.ravel(b.impacts), np.ravel(b.impact_tip_speeds)
    keep = speeds >= 0.05
    return times[keep], speeds[keep]


def render(times, speeds, *, snare="pearl2", room="live", sr=44100, snr_db=26.0, seed=0,
           spread_db=1.5, **options):
    """A recording of the roll from real hits (``options`` go to ``render_hits``)."""
    bank = HitBank.load([SAMPLES / f for f in SNARES[snare]], sr, level_spread_db=spread_db)
    return render_hits(times, speeds, bank=bank, room=MeasuredRoom.load(SAMPLES / ROOMS[room], sr),
                       disturbances=Disturbances(snr_db=snr_db), rng=np.random.default_rng(seed),
                       **options)


def numbered_errors(table, truth: np.ndarray) -> np.ndarray:
    """Each onset's error against the true impact its bounce number names (s); asserts that
    the numbers name the nearest impact (none one off, none spurious)."""
    nearest = np.array([int(np.argmin(np.abs(truth - t))) for t in table.time_s])
    np.testing.assert_array_equal(table.bounce, nearest)
    return table.time_s - truth[table.bounce]


def test_the_real_ping_pong_is_found_from_its_first_impact():
    """The bundled real ping-pong: its first and loudest impact (0.127 s) has 4.5 ms of
    faint sound before it (-50 dB) that the other impacts, landing in the ring of the one
    before, do not show; it was rejected as "before the roll" and every bounce numbered one
    too high."""
    truth = np.asarray(json.loads((DATA / "pingpong.truth.json").read_text())["onset_times_s"])
    table = detect(DATA / "pingpong.wav")
    assert len(table.rolls) == 1 and table.bounce[0] == 0
    ref = table.time_s <= truth[-1] + 0.002  # the reference stops at its 50th impact
    nearest = [int(np.argmin(np.abs(truth - t))) for t in table.time_s[ref]]
    np.testing.assert_array_equal(table.bounce[ref], nearest)  # every one numbered right
    err = table.time_s[ref] - truth[table.bounce[ref]]
    offset = np.median(err)
    assert abs(err[0] - offset) < 0.5e-3  # the first at the same point of its sound
    assert np.count_nonzero(np.abs(err - offset) < 2e-3) >= 49  # F1 >= 0.98 over the 50
    assert len(table) > truth.size  # and on into the bounces too faint to reference


#: Where a mains buzz hides the real ping-pong's first impact (2026-12-08). The click at
#: 0.1265 s is the first candidate's sound, but its detection function peaks 3.5 ms ahead of
#: it (the faint sound before the first impact, and the buzz's corners, lower the function at
#: the click itself), so its change point is looked for before the click and found on that
#: faint sound; the buzz puts it 1 ms further off than in the clean recording, where the
#: tracker keeps it (the flight law's stage then moves it onto the click), and here the
#: tracker drops it as "before the roll". Tried and not landed: looking for the click where
#: the detection function stays within a tenth of its peak, past an impact's rise time,
#: finds the first impact in all six buzz cases, but moves the clean recording's first
#: change point onto its faint lead-in and, through the flight law's stage and the loudest
#: impact's envelope, every onset with it (the ping-pong's MAD against its reference
#: 0.160 ms to 0.220).
BUZZ_HIDES_THE_FIRST = pytest.mark.xfail(
    strict=True, reason="the first candidate's change point is looked for ahead of the click "
    "(BUZZ_HIDES_THE_FIRST's comment)")


@pytest.mark.parametrize(("hz", "level"), [
    pytest.param(50, 0.01, marks=BUZZ_HIDES_THE_FIRST), (50, 0.05), (50, 0.2), (60, 0.01),
    (60, 0.05), pytest.param(60, 0.2, marks=BUZZ_HIDES_THE_FIRST)])
def test_mains_buzz_under_the_real_ping_pong_leaves_its_first_impact(hz, level):
    """A ground loop's buzz (the mains sine clipped to a near-square wave: odd harmonics far
    above the high-pass) at ``level`` times the recording's peak, 1 % being 40 dB under the
    loudest impact: the roll still starts at its first impact and every bounce is numbered
    right."""
    truth = np.asarray(json.loads((DATA / "pingpong.truth.json").read_text())["onset_times_s"])
    x, rate = sf.read(DATA / "pingpong.wav")
    t = np.arange(x.size) / rate
    buzz = level * np.abs(x).max() * np.clip(3.0 * np.sin(2.0 * np.pi * hz * t), -1.0, 1.0)
    table = detect(x + buzz, rate)
    assert abs(table.time_s[0] - truth[0]) < 2e-3 and table.bounce[0] == 0
    ref = table.time_s <= truth[-1] + 0.002
    nearest = [int(np.argmin(np.abs(truth - v))) for v in table.time_s[ref]]
    np.testing.assert_array_equal(table.bounce[ref], nearest)


@pytest.mark.parametrize("lead_s", [0.05, 0.1, 0.2])
def test_digital_silence_before_a_real_recording_is_no_roll(lead_s):
    """The real ping-pong after a stretch of exact zeros, as a recorder that pads its start
    or an editor writes it: the detection function's statistics counted the silence in, so
    the room's noise just after it (a ratio of 0 dB by construction, a MAD a third of the
    noise's) stood out as a roll of four "impacts" before the real one (0.100-0.222 s behind
    0.1 s of zeros). One roll, from the first impact, its onsets at the reference's."""
    x, sr = sf.read(DATA / "pingpong.wav")
    truth = np.asarray(json.loads((DATA / "pingpong.truth.json").read_text())["onset_times_s"])
    table = detect(np.concatenate([np.zeros(round(lead_s * sr)), x]), sr)
    assert len(table.rolls) == 1 and table.bounce[0] == 0
    ref = table.time_s - lead_s <= truth[-1] + 0.002  # the reference stops at its 50th
    err = table.time_s[ref] - lead_s - truth[table.bounce[ref]]
    offset = np.median(err)
    assert abs(err[0] - offset) < 0.5e-3  # the first at the same point of its sound
    assert np.count_nonzero(np.abs(err - offset) < 2e-3) >= 49  # as without the silence


@pytest.mark.parametrize("gate_db", [-60.0, -50.0])
def test_a_noise_gate_that_zeroes_the_quiet_samples_leaves_the_roll_whole(gate_db):
    """The real ping-pong with every sample under -60 or -50 dBFS set to zero (a crude noise
    gate): a sound gated to zeros right after an onset met log10(0), a RuntimeWarning on the
    user's terminal. No warning; one roll from the first impact."""
    import warnings

    x, sr = sf.read(DATA / "pingpong.wav")
    gated = np.where(np.abs(x) < 10 ** (gate_db / 20), 0.0, x)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        table = detect(gated, sr)
    mono = detect(x, sr)
    assert len(table.rolls) == 1 and table.bounce[0] == 0
    assert abs(table.time_s[0] - mono.time_s[0]) < 1e-4


@pytest.mark.parametrize("layout", ["dead right", "dead left", "dead middle of three"])
def test_a_dead_channel_leaves_the_onsets_those_of_the_live_one(layout):
    """The real ping-pong in a file with a channel of exact zeros beside it (a mono microphone
    on a stereo interface, a side muted in an editor): the silent channel's "onsets", put
    anywhere in each search, came first, so the roll was timed on it (onsets of amplitude 0,
    SNR -60 dB, sd 2 ms) or the follower met a NaN and stopped with an internal error. The
    channels compared are those that hear the impact: the onsets are the mono file's, to the
    sample."""
    x, sr = sf.read(DATA / "pingpong.wav")
    mono = detect(x, sr)
    zeros = np.zeros_like(x)
    channels = {"dead right": [x, zeros], "dead left": [zeros, x],
                "dead middle of three": [x, zeros, x]}[layout]
    table = detect(np.stack(channels, axis=1), sr)
    np.testing.assert_array_equal(table.time_s, mono.time_s)
    np.testing.assert_allclose(table.sigma_s, mono.sigma_s, rtol=1e-6)  # the mix's rounding


def test_a_hissing_dead_channel_is_not_the_one_the_roll_is_timed_on():
    """As above with hiss 90 dB under full scale in place of the zeros (an input with nothing
    plugged in): the candidates are found on the mix, whose searches start a little apart
    from the mono file's (onsets move by tenths of a millisecond with them, within their
    sigma_s, and the faint tail may differ), but the onsets are timed on the live channel:
    the first within 0.1 ms of the mono file's, nine in ten within 1 ms of one of them."""
    x, sr = sf.read(DATA / "pingpong.wav")
    mono = detect(x, sr)
    hiss = np.random.default_rng(0).normal(0.0, 10 ** (-90 / 20), x.size)
    for channels in ([x, hiss], [hiss, x]):
        table = detect(np.stack(channels, axis=1), sr)
        assert abs(table.time_s[0] - mono.time_s[0]) < 1e-4
        off = np.abs(table.time_s[:, None] - mono.time_s[None, :]).min(axis=1)
        assert np.mean(off < 1e-3) >= 0.9 and len(table) >= len(mono) - 4


def test_ping_pong_rolls_one_after_another_are_not_chained():
    """The real ping-pong three times in a row (0.4 s from one roll's last bounce to the
    next one's drop): the tracker chained the end of the first roll into the next two,
    through flights growing from 40 ms to 1.5 s, and reported one roll. Three rolls, each
    from its first impact."""
    x, sr = sf.read(DATA / "pingpong.wav")
    truth = np.asarray(json.loads((DATA / "pingpong.truth.json").read_text())["onset_times_s"])
    table = detect(np.tile(x, 3), sr)
    assert table.rolls == (0, 1, 2)
    for k in table.rolls:
        roll = table.select_roll(k)
        start = k * x.size / sr
        ref = roll.time_s <= start + truth[-1] + 0.002
        nearest = [int(np.argmin(np.abs(truth + start - t))) for t in roll.time_s[ref]]
        np.testing.assert_array_equal(roll.bounce[ref], nearest)  # every one numbered right
        err = roll.time_s[ref] - start - truth[roll.bounce[ref]]
        assert roll.bounce[0] == 0 and abs(err[0] - np.median(err)) < 0.5e-3
        assert ref.sum() >= 45


def test_a_hard_release_keeps_its_first_impact():
    """A stick thrown down at 0.9 m/s, and a faint side-stick tap 35 ms before its first
    impact: the tap, numbered first, made the real first impact (27 dB over its background)
    its "echo or double hit". Its flight to the first impact does not continue the roll's."""
    times, speeds = pendulum_roll(alpha=0.90, release=0.9)
    tap = HitBank.load([SAMPLES / "avl/37-SideStick-3.flac"], 96000)
    r = render(times, speeds, sr=96000, snr_db=26.0, room="hall", seed=3,
               extra_hits=[ExtraHit(tap, -0.035, level_db=-30.0, kind="tap")])
    table = detect(r.samples, r.sample_rate)
    err = numbered_errors(table, r.impact_times_s)
    assert table.bounce[0] == 0 and abs(err[0] - np.median(err)) < 0.5e-3
    assert len(table) >= np.count_nonzero(r.local_snr_db >= 0)


def test_a_roll_whose_level_does_not_fall_every_bounce():
    """Where a stick lands on the head changes a bounce's loudness: here the third and the
    sixth bounce are 9 dB louder than the ones before them. "A bounce is never louder than
    the one before it" cut such a roll at the louder bounce."""
    times, speeds = pendulum_roll(alpha=0.88)
    speeds = speeds.copy()
    speeds[[2, 5]] *= 10 ** (9.0 / 20.0 / 1.2)  # level ∝ speed^1.2
    r = render(times, speeds, snare="pearl", spread_db=0.0, seed=1)
    table = detect(r.samples, r.sample_rate)
    err = numbered_errors(table, r.impact_times_s)
    audible = np.flatnonzero(r.local_snr_db >= 0)
    assert audible.max() > 6 and set(audible) <= set(table.bounce)  # on past both
    assert np.all(np.abs(err - np.median(err)) < 2e-3)


def test_a_missed_bounce_in_the_middle_is_a_gap():
    """One bounce in the middle makes no sound (the stick grazed the rim): the flight across
    it is two flights, not a longer one. "The roll ends where a flight grows" ended the roll
    there; now the onsets after it are numbered on, with the gap."""
    times, speeds = pendulum_roll(alpha=0.88)
    silent = 6
    heard = np.delete(np.arange(times.size), silent)
    r = render(times[heard], speeds[heard], snare="porkpie", seed=2)
    truth = np.insert(r.impact_times_s, silent, np.nan)  # every impact, the silent one too
    table = detect(r.samples, r.sample_rate)
    nearest = [int(np.nanargmin(np.abs(truth - t))) for t in table.time_s]
    np.testing.assert_array_equal(table.bounce, nearest)
    assert silent not in table.bounce and table.bounce[-1] > silent + 3
    assert silent in table.gaps(0)


def test_stereo_is_timed_on_the_close_microphone():
    """A close and a farther microphone (0.3-2 ms later, more reverberant): the onsets are
    timed on the channel that hears them first, not on the two averaged (where each onset
    lands between the two arrivals, wherever the louder of them puts it)."""
    times, speeds = pendulum_roll(alpha=0.88)
    r = render(times, speeds, snare="porkpie", room="hall", channels=2, seed=4)
    assert r.channel_delays_s[1] > 0.3e-3
    table = detect(r.samples, r.sample_rate)
    assert table.channel == 0
    err = numbered_errors(table, r.impact_times_s)  # channel 0's truth
    loud = r.local_snr_db[table.bounce] >= 8.0
    assert loud.sum() >= 4
    assert np.max(np.abs(err[loud] - np.median(err[loud]))) < 0.15e-3


def test_the_first_impact_is_timed_at_the_same_point_of_its_sound_as_the_next():
    """The first impact lands in silence, the next ones in the ring of those before: on this
    snare (whose first 0.5 ms are 30 dB under its peak) the first was timed 0.6 ms earlier
    within its sound than the others, a level-dependent error that shortens the first
    flight. Timed as if it had landed in their ring, it is within 0.2 ms of them."""
    times, speeds = pendulum_roll(alpha=0.89)
    for seed, sr in ((0, 44100), (1, 48000), (2, 96000)):
        r = render(times, speeds, snare="pearl2", sr=sr, snr_db=30.0, seed=seed)
        err = numbered_errors(detect(r.samples, r.sample_rate), r.impact_times_s)
        assert abs(err[0] - np.median(err[1:6])) < 0.2e-3, (seed, err[:6])


def test_a_lossy_codecs_pre_echo_does_not_move_the_first_impact(tmp_path):
    """Vorbis spreads a loud click's sound up to a transform block (3 ms) before it; only the
    first impact, landing in silence, shows it."""
    times, speeds = pendulum_roll(alpha=0.88)
    r = render(times, speeds, snare="pearl", seed=5, snr_db=35.0)
    path = tmp_path / "roll.ogg"
    sf.write(path, r.samples, r.sample_rate, format="OGG", subtype="VORBIS")
    err = numbered_errors(detect(path), r.impact_times_s)
    assert abs(err[0] - np.median(err[1:6])) < 0.3e-3


@pytest.mark.parametrize("seed", [0, 1])
def test_faint_bounces_are_timed_where_their_sound_starts(seed):
    """On this snare a faint hit's first stage (its first 2 ms, 5 dB under the wires' slap
    5 ms later) is lost in the ring it lands in: it was timed at the slap, 4-6 ms late. Where
    the bounces before it put it, its first stage is found."""
    times, speeds = pendulum_roll(alpha=0.89, release=0.3)
    r = render(times, speeds, snare="pearl2", snr_db=30.0, seed=seed, clip_db=6.0)
    table = detect(r.samples, r.sample_rate)
    err = numbered_errors(table, r.impact_times_s)
    faint = r.local_snr_db[table.bounce] < 8.0
    assert faint.sum() >= 4
    assert np.all(np.abs(err - np.median(err))[faint] < 2e-3)


def test_the_real_ping_pong_fits_the_reference_power_law():
    """`estimate data/pingpong.wav --prior data/pingpong.toml`: a least-squares power law
    through the 50 reference impacts, with a contact time per impact as ``estimate`` has by
    default, gives alpha = 0.9436, t_B = 0.1941 s and tau_c = 2.5 ms (without the contact
    time: 0.9460 and 0.1937 s). Numbered one too high (the first impact dropped), t_B came
    out 0.183 s (a factor alpha short)."""
    import drumroll

    result = drumroll.estimate(DATA / "pingpong.wav", DATA / "pingpong.toml")
    alpha, t_b = result.parameter("alpha"), result.parameter("t_b")
    assert abs(alpha.mean - 0.9436) < 0.001
    assert abs(t_b.mean - 0.1941) < 0.002


@pytest.mark.skipif(not CORPUS.is_dir(), reason="the corpus (../shared/corpus) is not here")
@pytest.mark.parametrize("name", ["r01_pearl_d110", "r11_porkpie_stereo_reverb"])
def test_consistent_small_ring_alignments_still_move_the_first_impact(name):
    """On these real snares the next bounces align the first impact two samples earlier,
    every one of them: a lag that small is still a lag when the alignments agree (without it
    the first onset is 0.07 and 0.05 ms off the next ones' point of their sound)."""
    source = next(p for p in CORPUS.glob(name + ".*") if not p.name.endswith(".json"))
    truth = np.array(json.loads((CORPUS / f"{name}.truth.json").read_text())["onset_times_s"])
    table = detect(source)
    err = table.time_s - truth[table.bounce]
    assert abs(err[0] - np.median(err[1:6])) < 0.04e-3


def test_one_sharp_ring_alignment_still_moves_the_first_impact():
    """The benchmark's real-hit roll of a porkpie snare in the live room (20 dB, 48 kHz,
    seed 3): one bounce stands out of its ring enough to align the first impact on, and it
    puts the first onset 1.1 ms early in its sound (51 samples: the snare's first stage,
    under the ring for the next ones). A single alignment cannot show its error by
    disagreeing with others, but this one is sharp (its fit and its bounce's onset place it
    to 2.4 samples), and the first impact is moved by it."""
    rng = np.random.default_rng(20 * 1000 + 3)
    alpha, tb = rng.uniform(0.8, 0.95), rng.uniform(0.15, 0.4)
    flights = tb * alpha ** np.arange(1, 80)
    times = np.concatenate(([0.0], np.cumsum(flights[flights > 0.004])))
    speeds = rng.uniform(0.8, 1.6) * alpha ** np.arange(times.size)
    bank = HitBank.load([SAMPLES / f for f in SNARES["porkpie"]], 48000)
    r = render_hits(times, speeds, bank=bank,
                    room=MeasuredRoom.load(SAMPLES / ROOMS["live"], 48000),
                    disturbances=Disturbances(snr_db=20.0), rng=rng)
    err = numbered_errors(detect(r.samples, r.sample_rate), r.impact_times_s)
    assert abs(err[0] - np.median(err[1:6])) < 0.2e-3


def _faint_first_notes(table: OnsetTable) -> list[str]:
    """``estimate``'s notes on the roll's first onset being far fainter than the next."""
    from drumroll.pipeline import choose_roll

    return [n for n in choose_roll(table).notes if "fainter than the three" in n]


def test_a_first_onset_far_fainter_than_the_next_is_flagged():
    """``estimate``'s note on a first onset 20 dB or more under the three after it
    (:data:`~drumroll.pipeline.FAINT_FIRST_DB`): the bundled table2_h80 roll has none; with a
    tap 30 dB under its first impact put where the bounce before it would be (as the [simulate]
    section's taps land: the extractor took a sound before the roll for its first bounce in 3
    of 40 rolls, two of them 29 and 33 dB under), it has one, naming the tap's time."""
    roll = detect(str(DATA / "table2_h80.flac"))
    assert _faint_first_notes(roll) == []
    t = roll.time_s
    tap = t[0] - (t[1] - t[0]) / 0.9  # where the bounce before the first would be
    tap_level = roll.amplitude[0] * 10 ** (-30 / 20)
    tapped = OnsetTable(np.r_[tap, t], np.r_[tap_level, roll.amplitude],
                        np.r_[roll.snr_db[0] - 30, roll.snr_db],
                        np.r_[roll.sigma_s[0], roll.sigma_s],
                        bounce=np.r_[0, roll.bounce + 1], roll=np.r_[0, roll.roll])
    below = 20 * np.log10(np.median(roll.amplitude[:3]) / tap_level)
    notes = _faint_first_notes(tapped)
    assert len(notes) == 1 and f"({tap:.4f} s)" in notes[0] and f"{below:.0f} dB" in notes[0]


@pytest.mark.skipif(not CORPUS.is_dir(), reason="the corpus (../shared/corpus) is not here")
def test_a_real_first_impact_fainter_than_the_next_is_not_flagged():
    """Real sound: the claves roll of the shared corpus, whose first impact (a ball glancing off
    the claves) the extractor finds 14 dB under the next three, is fitted without the note
    (:data:`~drumroll.pipeline.FAINT_FIRST_DB`, 20 dB, is set above it)."""
    from drumroll.pipeline import FAINT_FIRST_DB

    claves = detect(str(CORPUS / "r12_ball_claves.wav"))
    first = claves.select_roll(claves.longest_roll)
    levels = 20 * np.log10(first.amplitude[:4])
    assert 10.0 < np.median(levels[1:4]) - levels[0] < FAINT_FIRST_DB  # a real faint first impact
    assert _faint_first_notes(claves) == []
