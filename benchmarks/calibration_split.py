"""Where an audio calibration's error bars fail: its coverage split by how the extractor heard
each roll and by the roll's true timing noise.

``drumroll calibrate --audio`` fits every simulated roll twice, from its onsets and from what
the extractor heard in its recording, and reports one coverage per quantity over all rolls
(``examples/output/calibrate-audio/``). This script reads its ``calibration.json`` and splits
the heard fits' 90 % coverage and the spread of z = (mean − truth) / sd:

* by hearing (the extractor's, before the estimate weighs the first onset's numbering and
  may drop it as a stray sound): the roll numbered from its first impact with every onset
  on its own impact; the first onset no impact of the roll (a tap before it); the first
  impact unheard; other misnumberings;
* among the rolls numbered right, by the true jitter of the roll's onsets (``--edges-ms``),
  beside the same rolls fitted from their simulated onsets, so that what the extractor
  changes shows apart from what a roll with that much noise can tell.

Each coverage is given with the binomial 99 % band a calibrated posterior's falls in for that
many rolls. Reads the file only: it takes a second.

Usage: ``python benchmarks/calibration_split.py
[examples/output/calibrate-audio/calibration.json] [--edges-ms 0.1 0.5 2]
[--quantities alpha t_b t0_s jitter_ms]``
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np
from scipy.stats import binom

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "examples" / "output" / "calibrate-audio" / "calibration.json"


def band(n: int, p: float = 0.9) -> tuple[float, float]:
    """The binomial 99 % band of a calibrated coverage over ``n`` rolls."""
    return binom.ppf(0.005, n, p) / n, binom.ppf(0.995, n, p) / n


def hearing_class(hearing: dict) -> str:
    """How the extractor heard a roll (``Hearing.first``: the true number of the first fitted
    onset, negative when it is no impact; ``misnumbered``: onsets off their impact)."""
    if hearing["first"] == 0 and not hearing["misnumbered"]:
        return "numbered right"
    if hearing["first"] < 0:
        return "extractor's first onset no impact"
    if hearing["first"] > 0:
        return "first impact unheard"  # (or numbered on from a later one)
    return "misnumbered later"


def rows(draws: list[dict], quantities: list[str], level: str) -> dict[str, tuple[float, float]]:
    """Coverage and z spread of each quantity at ``level`` ("audio" or "onsets")."""
    out = {}
    for key in quantities:
        covered = [d[level]["covered_90"][key] for d in draws if key in d[level]["covered_90"]]
        truth_key = "audio_t0_s" if key == "t0_s" and level == "audio" else None
        z = [((d[level]["mean"][key] - (d[truth_key] if truth_key else d["truth"][key]))
              / d[level]["sd"][key]) for d in draws if key in d[level]["mean"]]
        out[key] = (float(np.mean(covered)) if covered else np.nan,
                    float(np.std(z)) if z else np.nan)
    return out


def show(label: str, draws: list[dict], quantities: list[str], onsets_too: bool) -> None:
    n = len(draws)
    if n == 0:
        return
    low, high = band(n)
    heard = rows(draws, quantities, "audio")
    text = "  ".join(f"{k} {c:.2f}{'*' if not low <= c <= high else ' '} ({s:.2f})"
                     for k, (c, s) in heard.items())
    print(f"  {label:34s} {n:4d}  band {low:.2f}-{high:.2f}  heard: {text}")
    if onsets_too:
        fitted = rows(draws, quantities, "onsets")
        text = "  ".join(f"{k} {c:.2f}{'*' if not low <= c <= high else ' '} ({s:.2f})"
                         for k, (c, s) in fitted.items())
        print(f"  {'':34s} {'':4s}  {'':15s}  onsets: {text}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", nargs="?", type=Path, default=DEFAULT)
    parser.add_argument("--edges-ms", type=float, nargs="+", default=[0.1, 0.5, 2.0])
    parser.add_argument("--quantities", nargs="+", default=["alpha", "t_b", "t0_s",
                                                             "jitter_ms"])
    args = parser.parse_args()
    result = json.loads(args.path.read_text())
    draws = [d for d in result["draws"] if d.get("audio") and d.get("hearing")]
    print(f"{args.path}: {len(draws)} rolls heard; 90 % coverage of the heard fits (spread of "
          "z in brackets; * outside the band)")
    print("by hearing:")
    classes: dict[str, list[dict]] = {}
    for d in draws:
        classes.setdefault(hearing_class(d["hearing"]), []).append(d)
    show("all", draws, args.quantities, False)
    for name, members in classes.items():
        show(name, members, args.quantities, False)
    right = classes.get("numbered right", [])
    print("numbered right, by the roll's true jitter (and the same rolls fitted from their "
          "simulated onsets):")
    edges = [0.0, *args.edges_ms, np.inf]
    for lo, hi in itertools.pairwise(edges):
        members = [d for d in right if lo < d["truth"]["jitter_ms"] <= hi]
        show(f"jitter {lo:g} to {hi:g} ms", members, args.quantities, True)


if __name__ == "__main__":
    main()
