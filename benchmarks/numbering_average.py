"""Benchmark: α and t_B over the first onset's numberings against the fitted numbering's, on
the rolls of the audio calibration.

The rolls are ``drumroll calibrate data/table2_h80.toml --audio``'s (the same seeds: roll
``i`` of this script is draw ``i`` of that run): each drawn from the config's priors,
rendered with its ``[simulate]`` sound (the room, 30 dB of noise, hum, a tap 0.2 to 1 s
before the roll and a knock after it), its onsets found by the extractor and fitted as
``estimate`` fits them, the first onset's numbering weighed by the main model's evidences.
For each roll, the fitted numbering's 90 % highest-density intervals of α and t_B, and those
of the average over the numberings where the estimate gives one (``numbering_average``; else
the fit's own), are checked against the truth, with z = (mean − truth) / sd.

Prints the coverage of both with the binomial 99 % band, the rms of z, the same over the rolls
whose first fitted onset is the roll's first impact and over the others (a tap taken for the
first bounce, a missed first impact), and how many rolls the estimate averaged.

Run: ``python benchmarks/numbering_average.py [--n 200] [--first 0] [--workers 2]`` (about
7 CPU-s a roll).
"""

from __future__ import annotations

import argparse
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from scipy import stats

from drumroll.calibration.recording import Recorder, TooSlow
from drumroll.calibration.roll import RollSimulator
from drumroll.calibration.run import MIN_ONSETS, _truths, draw_seeds, fit_config
from drumroll.config import load_config
from drumroll.errors import AudioError, DrumrollError

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "data" / "table2_h80.toml"
#: The calibration's onsets per roll and its seed (``drumroll calibrate``'s defaults).
N_ONSETS, SEED = 16, 0
KEYS = ("alpha", "t_b")


def one_roll(index: int) -> dict | None:
    """Roll ``index``: drawn, rendered, heard and fitted as the audio calibration does; the
    fitted numbering's and the average's intervals of α and t_B against the truth."""
    from drumroll.pipeline import estimate

    config = load_config(CONFIG)
    roll_rng, sound_rng, _, fit_seed = draw_seeds(SEED, index)
    simulator = RollSimulator(config, config.model, N_ONSETS)
    recorder = Recorder(config)
    hearing = fit_config(config, fit_seed, numbering=True)
    for _ in range(50):  # a roll the pipeline cannot take is drawn again, as calibrate does
        roll = simulator.draw(roll_rng)
        try:
            heard = recorder.record(roll, sound_rng)
        except (TooSlow, AudioError):
            continue
        if heard.hearing.n_heard < MIN_ONSETS:
            continue
        try:
            result = estimate(heard.onsets, hearing, progress=False)
        except DrumrollError:
            continue
        break
    else:
        return None
    truth = _truths(result.fits[result.model].log_posterior, roll)
    summary = result.summary
    average = summary.numbering_average
    row = {"index": index, "first": heard.hearing.first, "averaged": average is not None,
           "weights": None if average is None else average.probabilities}
    for key in KEYS:
        for label, parameters in (("fit", summary.parameters),
                                  ("mix", summary.parameters if average is None
                                   else average.parameters)):
            p = parameters[key]
            row[f"{label}_{key}_covered"] = p.hdi_low <= truth[key] <= p.hdi_high
            row[f"{label}_{key}_z"] = (p.mean - truth[key]) / p.sd
    return row


def _line(rows: list[dict], what: str) -> str:
    n = len(rows)
    if not n:
        return f"{what}: none"
    band = stats.binom.ppf([0.005, 0.995], n, 0.9) / n
    parts = []
    for key in KEYS:
        for label in ("fit", "mix"):
            covered = sum(r[f"{label}_{key}_covered"] for r in rows)
            rms = math.sqrt(sum(r[f"{label}_{key}_z"] ** 2 for r in rows) / n)
            parts.append(f"{key} {label} {covered / n:.3f} (rms z {rms:.2f})")
    return (f"{what} ({n}; 99 % band {band[0]:.2f}-{band[1]:.2f}): " + ", ".join(parts))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    with ProcessPoolExecutor(args.workers) as pool:
        rows = [r for r in pool.map(one_roll, range(args.first, args.first + args.n))
                if r is not None]
    if not rows:
        sys.exit("no roll could be fitted")
    print(f"{'roll':>4} {'first':>5}  alpha: fit z / mix z   t_b: fit z / mix z   weights")
    for r in rows:
        if r["averaged"] or r["first"] != 0:
            print(f"{r['index']:4d} {r['first']:5d}  {r['fit_alpha_z']:+7.2f} / "
                  f"{r['mix_alpha_z']:+7.2f}      {r['fit_t_b_z']:+7.2f} / "
                  f"{r['mix_t_b_z']:+7.2f}     {r['weights']}")
    print()
    print(f"{sum(r['averaged'] for r in rows)} of {len(rows)} rolls averaged over their "
          "numberings; 90 % HDI coverage, fitted numbering (fit) and over the numberings "
          "(mix):")
    print(_line(rows, "all rolls"))
    print(_line([r for r in rows if r["first"] == 0], "first onset the roll's first impact"))
    print(_line([r for r in rows if r["first"] != 0],
                "first onset another sound or a later impact"))


if __name__ == "__main__":
    main()
