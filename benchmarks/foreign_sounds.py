"""The extractor and the estimate on rolls made of sounds drumroll's simulator does not make.

The rolls are ``tests/foreign_rolls.py``'s (damped sinusoids from zero phase and from their
crest, noise bursts, a sinusoid with a 1 ms attack, inharmonic modes; power-law flights,
α ~ U(0.85, 0.93), t_B ~ U(0.2, 0.3) s, 16 impacts, 0.1 ms timing noise), written to 16-bit
WAV files and run through ``drumroll.estimate`` with the power law (α and t_B flat, the jitter
log-uniform over 0.01-10 ms, the default contact prior), as a user's file would be.

Prints, per shape, frequency and noise level: how many rolls the extractor found from their
first impact, its F1 at ±2 ms and median timing error, the lateness of the last five onsets
against the first five (a sound that grows out of the noise is timed later the fainter it is,
so late as the bounces fade), and the estimate's 90 % coverage of α and t_B and the mean and
rms of z = (mean − truth) / sd; then the same pooled per shape and over all, with the
binomial 99 % band for that many rolls.

Usage: ``python benchmarks/foreign_sounds.py [--seeds 4] [--first-seed 0] [--frequencies 400
1000 3000] [--snr-db 40 20] [--shapes sine cosine noise attack modes] [--workers 2]`` (about
2 s per roll on one core). ``--first-seed 10 --seeds 12 --shapes sine cosine attack
--frequencies 1000 2000 3000 5000 --snr-db 40 30`` is the set of tone rolls on which a first
impact is lost most often (the tests' ``DECAY_INTO_NOISE`` comment says why).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import soundfile as sf
from scipy.stats import binom

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the rolls' one home, shared with the tests

import drumroll  # noqa: E402
from drumroll.config import parse_config  # noqa: E402
from foreign_rolls import POWER_LAW_PRIORS, SHAPES, draw_roll  # noqa: E402

RATE = 44100
TOLERANCE_S = 2e-3


def run(cell: tuple[str, float, float, int]) -> dict:
    """Extract and fit one roll: the extractor's matches and the estimate's α and t_B."""
    shape, frequency, snr_db, seed = cell
    samples, times, alpha, t_b = draw_roll(seed, shape, frequency, snr_db, RATE)
    config = parse_config({"model": "powerlaw", "compare": [], "priors": POWER_LAW_PRIORS,
                           "sampler": {"evidence": False, "workers": 1}})
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        path = Path(folder) / "roll.wav"
        sf.write(path, samples, RATE, subtype="PCM_16")
        result = drumroll.estimate(path, config)
    found = result.onsets.time_s
    nearest = np.abs(found[:, None] - times[None, :]).argmin(axis=0)
    errors = found[nearest] - times
    matched = np.abs(errors) <= TOLERANCE_S
    out = {"cell": cell, "n": times.size, "found": found.size, "tp": int(matched.sum()),
           "errors": errors[matched],
           "first": bool(found.size and abs(found[0] - times[0]) <= TOLERANCE_S)}
    for key, truth in (("alpha", alpha), ("t_b", t_b)):
        p = result.summary.parameters[key]
        out[key] = ((p.mean - truth) / p.sd, p.hdi_low < truth < p.hdi_high)
    return out


def line(label: str, rows: list[dict]) -> str:
    tp = sum(r["tp"] for r in rows)
    precision = tp / max(sum(r["found"] for r in rows), 1)
    recall = tp / sum(r["n"] for r in rows)
    f1 = 2 * precision * recall / max(precision + recall, 1e-12)
    errors = np.concatenate([r["errors"] for r in rows])
    late = [np.median(r["errors"][-5:]) - np.median(r["errors"][:5]) for r in rows
            if r["errors"].size >= 10]
    first = sum(r["first"] for r in rows)
    text = (f"{label:28s} {len(rows):4d} {first:5d} {f1:6.3f} {1e3 * np.median(errors):+8.3f} "
            f"{1e3 * np.median(late) if late else np.nan:+8.3f}")
    for key in ("alpha", "t_b"):
        z = np.array([r[key][0] for r in rows])
        covered = np.mean([r[key][1] for r in rows])
        text += f"   {covered:5.2f} {np.mean(z):+6.2f} {np.sqrt(np.mean(z**2)):5.2f}"
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--frequencies", type=float, nargs="+", default=[400, 1000, 3000])
    parser.add_argument("--snr-db", type=float, nargs="+", default=[40, 20])
    parser.add_argument("--shapes", nargs="+", choices=SHAPES, default=list(SHAPES))
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    cells = [(s, f, snr, seed) for s in args.shapes for f in args.frequencies
             for snr in args.snr_db
             for seed in range(args.first_seed, args.first_seed + args.seeds)]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(run, cells))
    header = (f"{'rolls':28s} {'n':>4s} {'first':>5s} {'F1':>6s} {'err ms':>8s} {'late ms':>8s}"
              f"   {'α: 90 %':>7s} {'z mean':>6s} {'rms':>5s}   {'t_B: 90 %':>9s}"
              f" {'mean':>4s} {'rms':>5s}")
    print("first: rolls whose first onset is their first impact; F1 at ±2 ms; err: median "
          "onset error;\nlate: median error of the last five onsets less the first five's; "
          "then per parameter the share of 90 % intervals holding the "
          "truth and the mean and rms of z = (mean - truth) / sd\n")
    print(header)
    for shape in args.shapes:
        for frequency in args.frequencies:
            for snr in args.snr_db:
                part = [r for r in rows if r["cell"][:3] == (shape, frequency, snr)]
                print(line(f"{shape} {frequency:g} Hz {snr:g} dB", part))
    print()
    for shape in args.shapes:
        print(line(f"{shape}, pooled", [r for r in rows if r["cell"][0] == shape]))
    low, high = (binom.ppf(q, len(rows), 0.9) / len(rows) for q in (0.005, 0.995))
    print(line("all", rows) + f"   (90 % band for {len(rows)} rolls: {low:.2f}-{high:.2f})")


if __name__ == "__main__":
    main()
