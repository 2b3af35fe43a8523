"""Following a roll into the noise (:mod:`drumroll.onsets.follow`).

The module promises: once a roll is tracked, the next impact is searched only in the window
its flights predict; a window with nothing significant is one unheard bounce, the search moves
on numbering on, and gives up after ``max_skip + 1`` empty windows in a row; it never looks
past ``stop_s``; sounds outside the predicted windows are not onsets. Checked on recordings
made here, clicks at the impact times of a geometric series with the truth known by
construction (one impact silent, several silent, jittered, a stray click mid-flight), and on
the real recording ``data/pingpong.wav`` against its reference times. The tail fit
:func:`_tail` is checked against an exponential sample, whose scale it must recover.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import soundfile as sf

from drumroll.onsets.excerpt import Excerpt
from drumroll.onsets.follow import FollowParams, _tail, follow
from drumroll.onsets.odf import OdfParams
from drumroll.onsets.roll import Roll
from paths import DATA

SR = 44100
N = 20
KNOWN = 5  # the roll handed to follow: the first five impacts


def impact_times(jitter_s: float = 0.0, seed: int = 0) -> np.ndarray:
    """τ_0 … τ_19 of a power-law roll (t_B = 0.25 s, α = 0.85) from 0.5 s, jittered."""
    times = 0.5 + np.r_[0.0, np.cumsum(0.25 * 0.85 ** np.arange(1, N))]
    return times + np.random.default_rng(seed).normal(0.0, jitter_s, N) * (np.arange(N) > 0)


def render(times: np.ndarray, amps: np.ndarray, snr_db: float = 40.0, seed: int = 0,
           tail_s: float = 0.5) -> np.ndarray:
    """Clicks (noise bursts with a 0.2 ms rise and 3 ms decay) at ``times`` in white noise
    ``snr_db`` below the loudest click's scale."""
    rng = np.random.default_rng(seed)
    n = int((times.max() + tail_s) * SR)
    x = np.zeros(n)
    for t, a in zip(times, amps, strict=True):
        n0 = math.ceil(t * SR)
        tt = np.arange(min(int(0.05 * SR), n - n0)) / SR + (n0 / SR - t)
        x[n0:n0 + tt.size] += a * -np.expm1(-tt / 2e-4) * np.exp(-tt / 3e-3) \
            * rng.standard_normal(tt.size)
    return x + 10 ** (-snr_db / 20) * rng.standard_normal(n)


def run(silent=(), jitter_s: float = 0.0, extra: tuple[float, float] | None = None,
        stop_s: float | None = None, params: FollowParams | None = None, seed: int = 0):
    """Render the roll with the ``silent`` impacts left out (and an ``extra`` click (time,
    amplitude)), hand follow its first five impacts; return the result and the truth."""
    times = impact_times(jitter_s, seed)
    amps = 0.85 ** np.arange(N)
    heard = np.setdiff1d(np.arange(N), silent)
    clicks, levels = times[heard], amps[heard]
    if extra is not None:
        clicks, levels = np.r_[clicks, extra[0]], np.r_[levels, extra[1]]
    x = render(clicks, levels, seed=seed)
    ex = Excerpt(x, 0, SR, OdfParams())
    k = np.arange(KNOWN)
    roll = Roll(times[k], k, amps[k], np.full(KNOWN, 30.0), np.full(KNOWN, 1e-4), amps[k])
    out = follow(roll, ex, params or FollowParams(), x.size / SR if stop_s is None else stop_s)
    return out, times, heard


def check_found(out: Roll, times: np.ndarray, expected: np.ndarray, tol: float = 5e-4):
    np.testing.assert_array_equal(out.bounce, expected)
    err = out.time_s - times[out.bounce]
    assert np.all(np.abs(err) < tol), np.round(1e3 * err, 3)
    assert np.all(np.diff(out.time_s) > 0)


def test_follows_a_roll_to_its_end():
    out, times, heard = run()
    check_found(out, times, heard)  # every impact, and nothing after the last one
    assert np.all(out.sigma_s[KNOWN:] > 0) and np.all(out.sigma_s[KNOWN:] < 5e-4)


@pytest.mark.parametrize("silent", [[9], [8, 9], [7, 12], [N - 1]])
def test_unheard_bounces_are_skipped_and_numbered_on(silent):
    out, times, heard = run(silent=silent)
    check_found(out, times, heard)


def test_more_unheard_bounces_than_max_skip_end_the_search():
    out, times, _ = run(silent=[9, 10, 11])  # three empty windows in a row: max_skip = 2
    check_found(out, times, np.arange(9))
    # a search allowed three skips crosses the gap
    out, times, heard = run(silent=[9, 10, 11], params=FollowParams(max_skip=3))
    check_found(out, times, heard)


def test_never_looks_past_stop():
    times = impact_times()
    stop = 0.5 * (times[11] + times[12])
    out, times, _ = run(stop_s=stop)
    check_found(out, times, np.arange(12))


@pytest.mark.parametrize("seed", range(3))
def test_jittered_impacts_are_found(seed):
    """Impact times off the geometric series by 0.5 ms rms: inside the predicted windows."""
    out, times, heard = run(jitter_s=5e-4, seed=seed)
    check_found(out, times, heard)


def test_a_click_between_the_predicted_windows_is_not_an_onset():
    times = impact_times()
    stray = times[10] + 0.5 * (times[11] - times[10])
    out, times, heard = run(extra=(stray, 0.5))  # louder than the impacts around it
    check_found(out, times, heard)
    assert np.min(np.abs(out.time_s - stray)) > 0.01


def test_a_roll_of_two_onsets_is_returned_as_it_is():
    times = impact_times()
    x = render(times, 0.85 ** np.arange(N))
    roll = Roll(times[:2], [0, 1], [1.0, 0.85], [30.0, 30.0], [1e-4, 1e-4], [1.0, 0.85])
    assert follow(roll, Excerpt(x, 0, SR, OdfParams()), FollowParams(), 10.0) is roll


def test_follows_the_real_ping_pong_ball():
    """Handed the first five referenced impacts, the search finds the 45 after them, each
    within 2 ms of its reference time (the reference was refined differently) and with its
    bounce number."""
    x, sr = sf.read(DATA / "pingpong.wav")
    truth = np.asarray(json.loads((DATA / "pingpong.truth.json").read_text())["onset_times_s"])
    k = np.arange(KNOWN)
    roll = Roll(truth[k], k, np.ones(KNOWN), np.full(KNOWN, 30.0), np.full(KNOWN, 1e-4),
                np.ones(KNOWN))
    out = follow(roll, Excerpt(x, 0, sr, OdfParams()), FollowParams(), x.size / sr)
    referenced = out.bounce < truth.size
    np.testing.assert_array_equal(out.bounce[referenced], np.arange(truth.size))
    err = out.time_s[referenced] - truth
    assert np.all(np.abs(err) < 0.002), np.round(1e3 * err, 2)


@pytest.mark.parametrize("q", [0.9, 0.95])
def test_tail_fit_recovers_an_exponential_scale(q):
    rng = np.random.default_rng(4)
    z = rng.exponential(0.7, 200_000) - 1.0
    u, exceed, beta = _tail(z, q)
    assert u == pytest.approx(-1.0 + 0.7 * math.log(1 / (1 - q)), rel=0.01)
    assert exceed == pytest.approx(1 - q)
    assert beta == pytest.approx(0.7, rel=0.02)
    # a roll's own impacts, far out in the tail, do not inflate the scale
    with_impacts = np.r_[z, np.full(50, 40.0)]
    assert _tail(with_impacts, q)[2] == pytest.approx(beta, rel=0.01)
    # nothing above the threshold: a unit scale
    assert _tail(np.zeros(100), q)[2] == 1.0


def test_a_roll_only_grows_forward():
    """An onset that is not after the roll's last (in time and bounce) is refused: the
    roll's columns keep one order, and the search cannot add the same impact again."""
    roll = Roll(np.array([0.5, 0.75]), np.array([0, 1]), np.ones(2), np.full(2, 20.0),
                np.full(2, 1e-4), np.ones(2))
    assert roll.with_onset(0.9, 3, 1.0, 20.0, 1e-4).bounce.tolist() == [0, 1, 3]
    for time_s, bounce in ((0.74, 2), (0.9, 1)):
        with pytest.raises(ValueError, match="not after the last"):
            roll.with_onset(time_s, bounce, 1.0, 20.0, 1e-4)


def test_an_onset_timed_back_into_its_flight_does_not_stall_the_search():
    """A recording ``calibrate --audio`` renders (table2_h80's priors, draw 28: a jitter of
    several ms makes flights grow and shrink) where the window after a 1.2 ms flight timed
    its onset 0.02 ms *before* the roll's last. It was added, sorted in before the last, and
    the same window was searched again for ever (over ten CPU-minutes). Now the extractor
    finishes, and every roll's onsets rise in time and in bounce number."""
    from drumroll.calibration.recording import Recorder
    from drumroll.calibration.roll import RollSimulator
    from drumroll.calibration.run import draw_seeds
    from drumroll.config import load_config

    config = load_config(DATA / "table2_h80.toml")
    roll_rng, sound_rng, _, _ = draw_seeds(0, 28)
    roll = RollSimulator(config, config.model, 20).draw(roll_rng)
    # Rendered, stored as 16-bit WAV and heard as calibrate does it, under its time limit
    # (TooSlow where the search would stall).
    onsets = Recorder(config).record(roll, sound_rng).onsets
    assert len(onsets) >= 4
    for number in np.unique(onsets.roll):
        mine = onsets.roll == number
        assert np.all(np.diff(onsets.time_s[mine]) > 0)
        assert np.all(np.diff(onsets.bounce[mine]) > 0)
