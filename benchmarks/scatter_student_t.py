"""Benchmark of the scattering restitution under Student-t noise (Laplace's method over T0
and the walk): this tree against a named revision, side by side in one run.

1. Per call: ``student_t_laplace`` for a sampler's half-ensemble of 64 points (near the
   onsets, and at differential-evolution proposals twice as far out) and
   ``student_t_laplace_pointwise`` (LOO's terms: one Laplace estimate per onset left out)
   for one chunk of 512 draws, this tree against the same functions of ``--against``
   (default b5fc1fa), imported from a temporary git worktree, on a power-law roll of 16
   onsets (0.1 % scatter, 0.1 ms t₄ jitter, one onset 2 ms late). Prints milliseconds per
   call (best of several), the ratio, and the largest difference of the two results; for
   LOO's terms also each tree's largest term. A term is ln p(t_i | t_−i), which the t's
   peak bounds (about 9 nats at these jitters); b5fc1fa started each roll less one onset
   from least squares at the t's centre, which with the late onset left in found a worse
   local mode of the integrand for a few draws (terms up to 60 nats), where starting from
   the whole roll's weights finds the better one.
2. End to end: ``estimate data/table2_h80.flac`` (Student-t noise) with the scatter in its
   priors (the README's line, ``restitution_scatter = { dist = "halfnormal", sigma = 0.02
   }``), both trees alternately (:func:`estimate.main_command`: medians, ratio, stages).

Run: ``python benchmarks/scatter_student_t.py [--against REV] [--repeats 2] [--skip-estimate]``.
"""

from __future__ import annotations

import sys
import timeit
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from estimate import worktree  # this folder's benchmarks
from scatter_likelihood import _module, benchmark_main

from drumroll.inference import scatter as this

#: The code before Laplace's method was made faster (powers as products, a line search that
#: takes a rise within its tolerance as none, LOO's terms started from the whole roll's
#: weights).
BEFORE = "b5fc1fa"
NU = 4.0


def _points(batch: int, spread_out: float, rng: np.random.Generator):
    """A power-law roll of 16 onsets under t₄ noise with a scattering restitution, and
    ``batch`` parameter points about it (each moving the impacts, the jitter and the scatter;
    ``spread_out`` scales how far): residuals, S and the t's squared scales per point."""
    n = 16
    flights = 0.25 * 0.9 ** np.arange(1, n)
    running = np.concatenate(([0.0], np.cumsum(flights)))
    g = np.array([[running[m] - running[j - 1] if j <= m else 0.0 for j in range(1, n)]
                  for m in range(n)])
    onsets = 0.0123 + g @ rng.normal(0.0, 1e-3, n - 1) + 1e-4 * rng.standard_t(NU, n)
    onsets[-3] += 2e-3  # a faint onset timed late
    moved = spread_out * 5e-5 * np.cumsum(rng.standard_normal((batch, n)), axis=1)
    jitter = 1e-4 * np.exp(spread_out * 0.3 * rng.standard_normal(batch))
    scatter = 1e-3 * np.exp(spread_out * 0.3 * rng.standard_normal(batch))
    spread = scatter[:, None, None] ** 2 * (g @ g.T)[None]
    return onsets[None] - moved, spread, np.repeat(jitter[:, None] ** 2, n, axis=1)


def per_call(against: str) -> None:
    rng = np.random.default_rng(0)
    cases = [("ln p, 64 points near the onsets", "student_t_laplace", _points(64, 1.0, rng), 30),
             ("ln p, 64 proposals farther out", "student_t_laplace", _points(64, 2.0, rng), 30),
             ("LOO's 16 terms, 512 draws", "student_t_laplace_pointwise",
              _points(512, 1.0, rng), 3)]
    with worktree(against) as tree:
        old = _module(tree / "src" / "drumroll" / "inference" / "scatter.py", "old_scatter")
        print(f"Student-t noise with the restitution's scatter, per call (ms), this tree "
              f"against {against}")
        print(f"  {'':34s} {'this tree':>10} {against:>10} {'ratio':>6}  largest |Δ|")
        for label, name, arguments, repeats in cases:
            ours_call = partial(getattr(this, name), *arguments, NU)
            theirs_call = partial(getattr(old, name), *arguments, NU)
            ours = min(timeit.repeat(ours_call, number=1, repeat=repeats)) * 1e3
            theirs = min(timeit.repeat(theirs_call, number=1, repeat=repeats)) * 1e3
            a, b = np.asarray(ours_call()), np.asarray(theirs_call())
            a, b = (a[0], b[0]) if name == "student_t_laplace" else (a, b)
            difference = np.max(np.abs(a - b))
            print(f"  {label:34s} {ours:10.2f} {theirs:10.2f} {ours / theirs:6.2f}  "
                  f"{difference:.1e} nat")
            if name == "student_t_laplace_pointwise":
                print(f"  {'  largest term (nat)':34s} {a.max():10.2f} {b.max():10.2f}")


if __name__ == "__main__":
    benchmark_main(__doc__.splitlines()[0], per_call, "table2_h80.flac", BEFORE, 2)
