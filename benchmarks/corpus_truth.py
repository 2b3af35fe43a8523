"""Truth check on recordings drumroll did not make: the shared corpus's drumstick rolls.

``../shared/corpus`` holds rolls of real recorded snare hits at impact times from an ODE
integration of the rigid pendulum (another simulator than ours), in measured rooms; its
impacts are instantaneous (0.1 ms of timing scatter, no contact time). Each drumstick roll is
estimated with the exact pendulum and the paper's kind of priors centred on its set-up
(d ± 2 mm, h ± 3 mm, the stick's lengths ± 1 mm, the release speed the corpus used, Student-t
noise), once with the default contact-time prior (none, or uniform over 0–3 ms, at even
odds) and once with the contact time fixed at 0 (``contact_ms = 0``, the truth of this
corpus), and α and t_B are
compared with the truth: each fit's z = (mean − truth) / sd, whether the 90 % highest-density
interval holds the truth, and over all rolls the coverage, the mean z and the spread of z.

With 11 rolls a coverage is known to about ± 0.1; what this shows is a bias common to the
rolls (the mean z), which a default prior at the edge of the truth can give.

Run: ``python benchmarks/corpus_truth.py [--corpus DIR]`` (about 2 minutes on two cores).
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

import drumroll
from drumroll.config import parse_config

CORPUS = Path(__file__).resolve().parents[2] / "shared" / "corpus"
#: The contact-time priors compared: the default, and none (the corpus's truth).
CONTACTS = {"default (0 or U 0-3 ms)": None, "fixed at 0": 0.0}


def roll_config(truth: dict, contact_ms: float | None):
    """The exact pendulum with priors centred on the roll's set-up (the paper's ±)."""
    priors = {"alpha": {"dist": "uniform", "low": 0.5, "high": 1.0},
              "pivot_mm": {"dist": "normal", "mu": truth["pivot_mm"], "sigma": 2},
              "height_mm": {"dist": "normal", "mu": truth["height_mm"], "sigma": 3},
              "release_speed_m_s": truth["release_tip_speed_m_s"]}
    if contact_ms is not None:
        priors["contact_ms"] = contact_ms
    return parse_config({
        "model": "pendulum", "compare": [],
        "stick": {"shape": "cylinder-cone", "radius_mm": 7.5,
                  "length_mm": {"dist": "normal", "mu": 348, "sigma": 1},
                  "tip_mm": {"dist": "normal", "mu": 60, "sigma": 1}},
        "priors": priors, "likelihood": {"noise": "student-t", "nu": 4},
        "sampler": {"evidence": False}})


def recording(truth_file: Path) -> Path:
    """The audio file beside ``<name>.truth.json``."""
    stem = truth_file.name.removesuffix(".truth.json")
    return next(p for p in truth_file.parent.glob(stem + ".*") if p.suffix != ".json")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, default=CORPUS, help="folder of rolls with truth")
    args = parser.parse_args()
    truths = [json.loads(f.read_text()) | {"file": f}
              for f in sorted(args.corpus.glob("*.truth.json"))]
    truths = [t for t in truths if t.get("kind") == "drumstick"]
    z = {label: {"alpha": [], "t_b": []} for label in CONTACTS}
    inside = {label: {"alpha": [], "t_b": []} for label in CONTACTS}
    print(f"{len(truths)} drumstick rolls of {args.corpus}; exact pendulum, priors on the "
          "set-up; z = (mean - truth) / sd; * = truth outside the 90 % interval")
    print(f"{'roll':28s} {'contact prior':20s} {'alpha':>17s} {'z':>6s} {'t_B (s)':>17s} "
          f"{'z':>6s} onsets")
    for truth in truths:
        expected = {"alpha": truth["alpha"], "t_b": truth["t_b_s"]}
        for label, contact in CONTACTS.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the fit's own warnings: not what is scored
                result = drumroll.estimate(recording(truth["file"]), roll_config(truth, contact))
            cells = []
            for key, true in expected.items():
                p = result.parameter(key)
                zi = (p.mean - true) / p.sd
                ok = p.hdi_low <= true <= p.hdi_high
                z[label][key].append(zi)
                inside[label][key].append(ok)
                cells.append(f"{p.mean:8.4f} ± {p.sd:6.4f} {zi:+6.1f}{' ' if ok else '*'}")
            print(f"{truth['case']:28s} {label:20s} {cells[0]} {cells[1]} "
                  f"{len(result.onsets):3d}/{len(truth['onset_times_s'])}", flush=True)
    print("\nover the rolls: 90 % coverage, mean z, spread of z (sd of z; 1 if the stated sd "
          "is the actual one)")
    for label in CONTACTS:
        for key in ("alpha", "t_b"):
            zs = np.array(z[label][key])
            print(f"  contact {label:20s} {key:6s} coverage {np.mean(inside[label][key]):.2f}  "
                  f"mean z {zs.mean():+.2f}  spread {zs.std(ddof=1):.2f}")


if __name__ == "__main__":
    main()
