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

from drumroll.inference.calibration import coverage

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "examples" / "output" / "calibrate-audio" / "calibration.json"


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


def rows(draws: list[dict], quantities: list[str], level: str) -> dict[str, tuple]:
    """The 90 % :func:`~drumroll.inference.calibration.coverage` and the spread of z of each
    quantity at ``level`` ("audio" or "onsets"; the heard fits' T0 has its own truth)."""
    out = {}
    for key in quantities:
        fits = [d for d in draws if key in d[level]["mean"]]
        truth = [d["audio_t0_s"] if key == "t0_s" and level == "audio" else d["truth"][key]
                 for d in fits]
        z = [(d[level]["mean"][key] - t) / d[level]["sd"][key]
             for d, t in zip(fits, truth, strict=True)]
        out[key] = (coverage([d[level]["covered_90"][key] for d in fits], 0.9),
                    float(np.std(z)) if z else np.nan)
    return out


def show(label: str, draws: list[dict], quantities: list[str], onsets_too: bool) -> None:
    """One line per level: each quantity's coverage (* outside the band) and z spread."""
    if not draws:
        return
    levels = ("audio", "onsets") if onsets_too else ("audio",)
    for level in levels:
        found = rows(draws, quantities, level)
        text = "  ".join(f"{k} {c.rate:.2f}{' ' if c.inside else '*'} ({s:.2f})"
                         for k, (c, s) in found.items())
        some = next(iter(found.values()))[0]
        head = (f"{label:34s} {len(draws):4d}  band {some.band_low:.2f}-{some.band_high:.2f}"
                if level == "audio" else f"{'':34s} {'':4s}  {'':15s}")
        print(f"  {head}  {'heard' if level == 'audio' else 'onsets'}: {text}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", nargs="?", type=Path, default=DEFAULT)
    parser.add_argument("--edges-ms", type=float, nargs="+", default=[0.1, 0.5, 2.0])
    parser.add_argument("--quantities", nargs="+", default=["alpha", "t_b", "t0_s",
                                                             "jitter_ms"])
    args = parser.parse_args()
    try:
        result = json.loads(args.path.read_text())
    except (OSError, ValueError) as exc:
        parser.error(f"{args.path}: not a calibration.json ({exc})")
    draws = [d for d in result.get("draws", []) if d.get("audio") and d.get("hearing")]
    if not draws:
        parser.error(f"{args.path}: no roll was heard (run drumroll calibrate with --audio)")
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
