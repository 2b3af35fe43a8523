"""The extractor on sounds the project's own simulator does not make (``tests/foreign_rolls.py``:
damped tones, noise bursts, a slow attack, inharmonic modes), as another simulator or another
bouncer would give them."""

from __future__ import annotations

import numpy as np
import pytest

from drumroll.onsets import detect
from drumroll.onsets.candidates import CandidateStream
from drumroll.onsets.odf import OdfParams, noise_spreads
from foreign_rolls import ATTACK_S, SHAPES, draw_roll, foreign_roll

RATE = 44100


#: Why the extractor fails where it does on these sounds (strict: a change that mends one is
#: noticed). The detection function of a band is standardised by its own local median and
#: spread (:func:`drumroll.onsets.peaks.local_robust_z`). A pure tone's smooth decay makes
#: that band's rise ratio far steadier than noise makes it, and puts its median below no
#: change (a 20 ms decay: about -3 dB); against those, the noise the tone decays into reads as
#: rises: candidates between the impacts, which the tracker can follow as a roll of their own.
#: A band far steadier than noise is now judged by noise's spread when candidates are found
#: (:data:`drumroll.onsets.peaks.STEADY`), which mends the 3 kHz roll below and most tone
#: rolls (``test_tone_rolls_are_found_from_their_first_impact``). Tried on 2026-12-06 and not
#: landed: bounding every band's spread by noise's mends the second tone case too, and finds
#: the first impact of every tone roll, but moves onsets of the bundled recordings by up to
#: 0.8 ms and fails five tests (an exact-pendulum roll called inadequate, a bounce
#: misnumbered, 96 kHz timing, a faint roll not found); centring each band at no change at the least
#: as well mends the first tone case, but lowers F1 at 12 dB (0.981 to 0.976, 0.742 to 0.738).
DECAY_INTO_NOISE = pytest.mark.xfail(
    strict=True, reason="the noise after a pure tone's smooth decay stands out against the "
    "decay's own statistics (DECAY_INTO_NOISE's comment)")


@pytest.mark.parametrize(("spacing", "noise_db"), [
    pytest.param(0.2, -45.0, marks=DECAY_INTO_NOISE),
    pytest.param(0.15, -40.0, marks=DECAY_INTO_NOISE)])
def test_pure_tones_dying_into_noise_leave_no_candidates_behind(spacing, noise_db):
    """Damped 3 kHz tones every ``spacing`` seconds in white noise: their starts are the only
    candidates (today five and three more, between them)."""
    rng = np.random.default_rng(0)
    starts = 0.5 + spacing * np.arange(8)
    x = np.zeros(int((starts[-1] + 0.3) * RATE))
    t = np.arange(int(0.3 * RATE)) / RATE
    for start in starts:
        first = int(start * RATE)
        stop = min(first + t.size, x.size)
        x[first:stop] += (np.sin(2 * np.pi * 3000 * t) * np.exp(-t / 0.02))[: stop - first]
    x += rng.standard_normal(x.size) * 10 ** (noise_db / 20)
    stream = CandidateStream(RATE)
    stream.feed(x)
    found = stream.finish().time_s
    assert found.size == starts.size, np.round(found, 4)
    assert np.max(np.abs(found - starts)) < 0.2e-3


def test_the_noise_spread_is_that_of_noise():
    """The spread a band is judged by when it is far steadier than noise is noise's own: it
    narrows from the lowest band to the highest (a wider band sums more independent values
    per window), and the top band's is chi-square's for its time-bandwidth product."""
    params = OdfParams()
    pre, post = params.frames(params.pre_s, RATE), params.frames(params.post_s, RATE)
    bands, total = noise_spreads(params, RATE, pre, post)
    assert np.all(np.diff(bands) < 0), bands
    # About 2 B T degrees of freedom per window, B the band's noise bandwidth and T the
    # window's length: the top band, a high-pass from 12.15 kHz to 22.05 kHz, scatters by
    # 4.34 dB x sqrt(1 / (B x 5 ms) + 1 / (B x 10 ms)), about 0.75 dB.
    assert 0.55 < bands[-1] < 0.85, bands
    assert total > 0.0


#: (shape, frequency) cells the extractor fails today, and how.
FAILING = {("sine", 400): "the last three impacts are lost"}


@pytest.mark.parametrize(("shape", "frequency"), [
    pytest.param(shape, frequency, marks=[DECAY_INTO_NOISE] if (shape, frequency) in FAILING
                 else [], id=f"{shape}-{frequency}")
    for shape in SHAPES for frequency in (400, 3000)])
def test_a_foreign_roll_is_found_from_its_first_impact(shape, frequency):
    """At 40 dB the roll is found from its first impact, every onset on an impact, within
    0.3 ms (the 1 ms attack's within its rise: it is timed where the rise leaves the noise),
    and at most one impact left out (``FAILING`` says where that fails, today)."""
    samples, times, _, _ = draw_roll(3, shape, frequency, 40.0, RATE)
    found = detect(samples, RATE).time_s
    assert found.size >= times.size - 1, (np.round(found, 4), np.round(times, 4))
    nearest = np.abs(found[:, None] - times[None, :]).argmin(axis=1)
    errors = found - times[nearest]
    within = ATTACK_S if shape == "attack" else 0.3e-3
    assert nearest[0] == 0 and np.max(np.abs(errors)) < within, np.round(1e3 * errors, 3)


@pytest.mark.slow
def test_tone_rolls_are_found_from_their_first_impact():
    """144 rolls of damped tones (from zero phase, from the crest, with a 1 ms attack; 1, 2,
    3 and 5 kHz; 12 seeds each) at 40 dB, where a tone decays furthest before it meets the
    noise: the first onset is the first impact in all but 10 (7 today; 18 while a band far
    steadier than noise was judged by its own spread, the tracker then following the noise
    after the second impact as a roll and losing the first two)."""
    lost = []
    for shape in ("sine", "cosine", "attack"):
        for frequency in (1000, 2000, 3000, 5000):
            for seed in range(10, 22):
                samples, times, _, _ = draw_roll(seed, shape, frequency, 40.0, RATE)
                found = detect(samples, RATE).time_s
                if abs(found[0] - times[0]) > 2e-3:
                    lost.append((shape, frequency, seed))
    assert len(lost) <= 10, lost


def _quantised(x: np.ndarray) -> np.ndarray:
    """``x`` as a 16-bit file holds it."""
    return np.round(np.clip(x, -1.0, 1.0) * 32767.0) / 32767.0


@pytest.mark.parametrize("silence", ["under the last bit", "noise gate", "lead-in of zeros"])
def test_digital_silence_leaves_every_onset_timed(silence):
    """A recording whose quiet stretches are exactly constant, as a 16-bit file of a clean
    sound (its noise under the last bit), a phone's noise gate or an editor's inserted
    silence make them: the band power there is 0, whose logarithm the alignment of the
    first impact with the ringing bounces once took, leaving the first onset's sigma_s NaN
    (and, in a recording ending in a quantised hum, an internal error). Every impact found
    within 1 ms, every sigma_s finite and positive."""
    rng = np.random.default_rng(4)
    x, times = foreign_roll(rng, "modes", 1500.0, 200.0, alpha=0.9, t_b=0.25, rate=RATE)
    if silence == "noise gate":
        x = np.where(np.abs(x) < 10 ** (-50 / 20), 0.0, x)
    elif silence == "lead-in of zeros":
        x, times = np.concatenate([np.zeros(RATE), x]), times + 1.0
    table = detect(_quantised(x), RATE)
    assert np.all(np.isfinite(table.sigma_s)) and np.all(table.sigma_s > 0)
    nearest = np.min(np.abs(table.time_s[:, None] - times[None, :]), axis=0)
    assert np.all(nearest < 1e-3), nearest
