"""Benchmark of ``estimate``: the README's main command, and the sampler against emcee's default.

1. Wall time of ``estimate data/table2_h80.flac --prior data/table2_h80.toml`` (exact
   pendulum compared with small-angle and power law, evidences, every figure), run as a user
   runs it, with the time split by stage from ``summary.json``.
2. Effective samples of α per second: drumroll's sampler (differential-evolution moves, run to
   R-hat < 1.01, ESS ≥ 400 and 50 τ) against emcee's default stretch move given the same number
   of steps, side by side on the same posterior (bundled recording's onsets).

Run: ``python benchmarks/estimate.py [--source data/table2_h80.flac] [--repeats 3]``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import arviz as az
import emcee
import numpy as np

from drumroll.config import load_config
from drumroll.inference.mode import find_mode
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.sampling import SamplerSettings, initial_ball, run_emcee
from drumroll.inference.settings import estimate_settings
from drumroll.pipeline import choose_roll, load_onsets

ROOT = Path(__file__).resolve().parents[1]


def main_command(source: Path, config: Path, repeats: int) -> None:
    """Run the README's main command ``repeats`` times; print the median wall time and the
    stages of that run (start-up = imports and config; the rest from the progress lines and
    ``summary.json``)."""
    runs = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "out"
            command = ["estimate", str(source), "--prior", str(config), "--out", str(out)]
            started = time.perf_counter()
            proc = subprocess.run(command, capture_output=True, text=True, check=False)
            wall = time.perf_counter() - started
            if proc.returncode != 0:
                print(f"main command failed ({proc.returncode}): {proc.stderr.strip()}")
                return
            summary = json.loads((out / "summary.json").read_text())
            stages = dict(re.findall(r"^(estimating|writing) .*: done in ([\d.]+) s$",
                                     proc.stderr, flags=re.MULTILINE))
            runs.append((wall, summary, {k: float(v) for k, v in stages.items()}))
    runs.sort(key=lambda run: run[0])
    wall, summary, stages = runs[len(runs) // 2]
    print(f"main command: {' '.join(command[:4])} … on {os.cpu_count()} cores")
    print(f"  wall time {wall:.1f} s, median of {repeats} "
          f"(all: {', '.join(f'{r[0]:.1f}' for r in runs)} s; goal ≤ 20 s)")
    startup = wall - stages.get("estimating", 0.0) - stages.get("writing", 0.0)
    print(f"  {'start-up (imports)':<24} {startup:6.1f} s")
    print(f"  {'estimating':<24} {stages.get('estimating', float('nan')):6.1f} s, of which")
    for stage, seconds in summary["seconds"].items():
        print(f"    {stage:<22} {seconds:6.1f} s")
    print(f"  {'writing (figures, nc)':<24} {stages.get('writing', float('nan')):6.1f} s")
    alpha = summary["parameters"]["alpha"]
    print(f"  α = {alpha['mean']:.4f} ± {alpha['sd']:.4f}, ESS bulk {alpha['ess_bulk']:.0f}, "
          f"R-hat {alpha['r_hat']:.3f}; preferred: {summary['preferred']}")


def ess_alpha(chain: np.ndarray) -> float:
    """Bulk ESS of α from a (walkers, draws) array."""
    return float(az.ess(chain, method="bulk"))


def sampler_peer(source: Path, config: Path) -> None:
    cfg = load_config(config)
    data = choose_roll(load_onsets(source)).data  # the roll estimate fits, as it numbers it
    settings = estimate_settings(cfg.sections)  # the config's noise model, as estimate uses
    log_posterior = LogPosterior.build(cfg, "pendulum", data, settings.noise, settings.nu)
    i_alpha = log_posterior.space.names.index("alpha")

    started = time.perf_counter()
    ours = run_emcee(log_posterior, SamplerSettings(seed=1))
    ours_seconds = time.perf_counter() - started
    ours_ess = ess_alpha(ours.samples[..., i_alpha])

    rng = np.random.default_rng(1)
    started = time.perf_counter()
    start = initial_ball(log_posterior, find_mode(log_posterior, rng), 32, rng)
    peer = emcee.EnsembleSampler(32, log_posterior.space.ndim, log_posterior, vectorize=True)
    peer.run_mcmc(start, ours.n_steps, progress=False)
    peer_seconds = time.perf_counter() - started
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tau = peer.get_autocorr_time(tol=0)
    burn = min(int(3 * np.nanmax(tau)), ours.n_steps // 2)
    peer_chain = np.swapaxes(peer.get_chain(discard=burn), 0, 1)[..., i_alpha]
    peer_ess = ess_alpha(peer_chain)
    print(f"\nsampler, exact pendulum posterior of {source.name} ({data.n_onsets} onsets, "
          f"{log_posterior.space.ndim} parameters, 32 walkers, {ours.n_steps} steps each)")
    print(f"  drumroll (DE moves):         τ_max {np.nanmax(ours.tau):6.0f} steps, "
          f"ESS(α) {ours_ess:7.0f}, {ours_seconds:5.1f} s, {ours_ess / ours_seconds:7.0f} ESS/s, "
          f"R-hat(α) {float(az.rhat(ours.samples[..., i_alpha])):.3f}")
    print(f"  emcee default (stretch):     τ_max {np.nanmax(tau):6.0f} steps, "
          f"ESS(α) {peer_ess:7.0f}, {peer_seconds:5.1f} s, {peer_ess / peer_seconds:7.0f} ESS/s, "
          f"R-hat(α) {float(az.rhat(peer_chain)):.3f}")
    print(f"  ratio (ESS/s): {ours_ess / ours_seconds / (peer_ess / peer_seconds):.2f}×")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=ROOT / "data" / "table2_h80.flac")
    parser.add_argument("--config", type=Path, default=None)
    parser.add_argument("--skip-main", action="store_true")
    parser.add_argument("--repeats", type=int, default=3, help="runs of the main command")
    args = parser.parse_args()
    config = args.config or args.source.with_suffix(".toml")
    if not args.skip_main:
        main_command(args.source, config, args.repeats)
    sampler_peer(args.source, config)


if __name__ == "__main__":
    sys.exit(main())
