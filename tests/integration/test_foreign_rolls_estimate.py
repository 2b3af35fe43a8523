"""Honest error bars on recordings made by another simulator: ``estimate`` on rolls of sounds
drumroll's own renderer does not make (``tests/foreign_rolls.py``), written to WAV files as a
user's would be. ``benchmarks/foreign_sounds.py`` prints the same over 120 rolls (α's 90 %
intervals hold the truth in 0.91 of them, t_B's in 0.93)."""

from __future__ import annotations

import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
import soundfile as sf
from scipy.stats import binom

import drumroll
from drumroll.config import parse_config
from foreign_rolls import POWER_LAW_PRIORS, SHAPES, draw_roll

pytestmark = pytest.mark.slow

RATE = 44100
CELLS = [(shape, frequency, snr) for shape in SHAPES for frequency in (400, 1000, 3000)
         for snr in (40.0, 20.0)]


def fit(cell: tuple[str, int, float], folder: str) -> list[tuple[float, bool]]:
    """One roll of ``cell`` fitted with the power law: (z, covered) of α and of t_B."""
    shape, frequency, snr = cell
    samples, _, alpha, t_b = draw_roll(0, shape, frequency, snr, RATE)
    path = f"{folder}/{shape}-{frequency}-{snr:g}.wav"
    sf.write(path, samples, RATE, subtype="PCM_16")
    config = parse_config({"model": "powerlaw", "compare": [], "priors": POWER_LAW_PRIORS,
                           "sampler": {"evidence": False, "workers": 1}})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        parameters = drumroll.estimate(path, config).summary.parameters
    out = []
    for key, truth in (("alpha", alpha), ("t_b", t_b)):
        p = parameters[key]
        out.append(((p.mean - truth) / p.sd, p.hdi_low < truth < p.hdi_high))
    return out


def test_alpha_and_t_b_hold_the_truth_on_rolls_of_foreign_sounds(tmp_path):
    """30 rolls (five sound shapes, three frequencies, 40 and 20 dB): the 90 % intervals of α
    and t_B hold the truth at a rate inside the binomial 99 % band, and z = (mean - truth) /
    sd has an rms of at most 1.5 (a misnumbered roll, its t_B a bounce off, gives hundreds)."""
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(fit, CELLS, [str(tmp_path)] * len(CELLS)))
    low = binom.ppf(0.005, len(CELLS), 0.9) / len(CELLS)
    for i, name in enumerate(("alpha", "t_b")):
        z = np.array([r[i][0] for r in results])
        covered = np.mean([r[i][1] for r in results])
        assert covered >= low, (name, covered, low)
        assert np.sqrt(np.mean(z**2)) <= 1.5, (name, np.round(z, 2))
