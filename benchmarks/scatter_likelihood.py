"""Benchmark of the scattering restitution's Gaussian likelihood: this tree against a named
revision, side by side in one run.

1. Per call: ``scatter_marginal`` (here a Kalman filter along the roll, O(K) per parameter
   point) against the same function of ``--against`` (default 5bb0466: the onsets'
   covariance Σ formed, then one bordered Cholesky factor per point), imported from a
   temporary git worktree, on power-law rolls of 16 and 55 onsets (bounces 5 and 9 unheard),
   for a sampler's half-ensemble of 64 walkers and for a start search's 10,000 points.
   Prints milliseconds per call, the ratio, and the largest difference of the two
   log-likelihoods (the same number, rounded differently).
2. End to end: ``estimate data/pingpong.wav`` with the scatter in its priors (the README's
   one line, ``restitution_scatter = { dist = "halfnormal", sigma = 0.02 }``), both trees
   alternately (:func:`estimate.main_command`: medians, ratio, stages).

Run: ``python benchmarks/scatter_likelihood.py [--against REV] [--repeats 3] [--skip-estimate]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
import timeit
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from estimate import main_command, worktree  # this folder's benchmark

from drumroll.inference.likelihood import OnsetData
from drumroll.inference.scatter import scatter_marginal

ROOT = Path(__file__).resolve().parents[1]
#: The code before the filter: Σ formed and factorised per parameter point.
BEFORE = "5bb0466"
SCATTER_LINE = 'restitution_scatter = { dist = "halfnormal", sigma = 0.02 }'


def _module(path: Path, name: str):
    """The module at ``path``, imported under ``name`` (its own imports resolve to this
    tree's package, whose interfaces it uses are unchanged)."""
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # where a dataclass of the module looks itself up
    spec.loader.exec_module(module)
    return module


def _roll(n_onsets: int, batch: int, rng: np.random.Generator):
    """A power-law roll of ``n_onsets`` onsets (bounces 5 and 9 unheard) and ``batch``
    parameter points near it: data, impacts, slopes, jitter, scatter."""
    k_max = n_onsets + 1
    bounces = np.setdiff1d(np.arange(k_max + 1), [5, 9])
    alpha = 0.95 + 1e-4 * rng.standard_normal(batch)
    t_b = 0.25 + 1e-4 * rng.standard_normal(batch)
    flights = t_b[:, None] * alpha[:, None] ** np.arange(1, k_max + 1)
    impacts = np.concatenate([np.zeros((batch, 1)), np.cumsum(flights, axis=1)], axis=1)
    times = 1.0 + impacts[0, bounces] + rng.normal(0, 2e-4, bounces.size)
    data = OnsetData.from_arrays(times, np.full(bounces.size, 5e-5), bounces)
    jitter = 1e-4 * np.exp(0.3 * rng.standard_normal(batch))
    scatter = 0.004 * np.exp(0.3 * rng.standard_normal(batch))
    return data, impacts, flights, jitter, scatter  # geometric flights: slope_k = T_k


def _dense(old, data, impacts, slopes, jitter, scatter):
    """The revision's likelihood: Σ formed, then factorised (its own two functions)."""
    return old.scatter_marginal(data, impacts, old.onset_covariance(data, slopes, jitter,
                                                                    scatter))


def per_call(against: str) -> None:
    rng = np.random.default_rng(0)
    with worktree(against) as tree:
        old = _module(tree / "src" / "drumroll" / "inference" / "scatter.py", "old_scatter")
        print(f"Gaussian likelihood with the restitution's scatter, per call (ms), this tree "
              f"against {against}")
        print(f"  {'onsets':>6} {'points':>6} {'this tree':>10} {against:>10} {'ratio':>6}"
              f"  largest |Δ ln L|")
        for n_onsets in (16, 55):
            for batch in (64, 10_000):
                data, impacts, slopes, jitter, scatter = _roll(n_onsets, batch, rng)
                repeats = 20 if batch < 1000 else 3
                new = partial(scatter_marginal, data, impacts, slopes, jitter, scatter)
                before = partial(_dense, old, data, impacts, slopes, jitter, scatter)
                ours = min(timeit.repeat(new, number=1, repeat=repeats)) * 1e3
                theirs = min(timeit.repeat(before, number=1, repeat=repeats)) * 1e3
                difference = np.max(np.abs(new()[0] - before()[0]))
                print(f"  {n_onsets:6d} {batch:6d} {ours:10.2f} {theirs:10.2f} "
                      f"{ours / theirs:6.2f}  {difference:.1e}")


def end_to_end(recording: str, against: str, repeats: int) -> None:
    """``estimate data/<recording>`` with its bundled config and the scatter's prior line
    added, both trees alternately (:func:`estimate.main_command`)."""
    source = ROOT / "data" / recording
    text = source.with_suffix(".toml").read_text()
    with_scatter = text.replace("[priors]\n", f"[priors]\n{SCATTER_LINE}\n", 1)
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / f"{source.stem}_scatter.toml"
        config.write_text(with_scatter)
        print(f"\nestimate data/{recording} with {SCATTER_LINE}")
        main_command(source, config, repeats, against, goal=None)


def benchmark_main(description: str, per_call, recording: str, before: str,
                   repeats: int) -> None:
    """The command line of a scatter benchmark: ``per_call(against)``, then
    :func:`end_to_end` on ``recording`` unless ``--skip-estimate``."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--against", default=before,
                        help=f"git revision to compare with (default {before})")
    parser.add_argument("--repeats", type=int, default=repeats,
                        help="estimate runs of each tree")
    parser.add_argument("--skip-estimate", action="store_true",
                        help="only the per-call costs")
    args = parser.parse_args()
    per_call(args.against)
    if not args.skip_estimate:
        end_to_end(recording, args.against, args.repeats)


if __name__ == "__main__":
    benchmark_main(__doc__.splitlines()[0], per_call, "pingpong.wav", BEFORE, 3)
