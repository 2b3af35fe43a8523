"""Cost of the inference pipeline per model: log-posterior calls, emcee, dynesty.

    python benchmarks/likelihood.py            # everything (~1 min on 2 cores)
    python benchmarks/likelihood.py --quick    # per-call costs only
    python benchmarks/likelihood.py --gap      # the same roll with bounces 5 and 12 unheard

Set-up: the exact pendulum (α = 0.88, d = 131, h = 80 mm, 25 flights, 0.1 ms jitter) under
data/table1_d131.toml, fitted by each model. Prints µs per ``LogPosterior`` call for batches of
1, 16 and 64 (and the one-point likelihood dynesty calls), emcee steps/s and effective samples
of α per second, dynesty calls and seconds, and ln Z by dynesty and by importance sampling.

"Before" figures (measured at commit 1291f1e on the same shared 2-core machine, other jobs
running; min of 3 repeats):

    model        batch1  batch16  batch64  1-pt like | emcee: steps  tau_max  s     ESS(α)/s
    pendulum     171 µs  214 µs   344 µs   127 µs    |       11000   87      32.0   126
    small-angle  146 µs  136 µs   152 µs    89 µs    |        4500   36      13.8   312
    powerlaw      67 µs   64 µs    79 µs    40 µs    |        1500   15       2.8  1195
    dynesty (rwalk, 200 live, dlogz 0.1, unit cube through the priors' ppf):
    pendulum 110,555 calls 55.0 s; small-angle 77,345 calls 21.3 s; powerlaw 90,375 calls 7.4 s
    (two runs side by side). Its pendulum ln Z was 179.78, 178.70 and 176.58 on seeds 0-2
    against 179.866 ± 0.002 by importance sampling: 1-3 nats low on two seeds of three.
    emcee also used DESnookerMove, which in emcee 3.1.6 does not keep the target invariant.
"""

from __future__ import annotations

import argparse
import time
import timeit
from pathlib import Path

import arviz as az
import numpy as np

from drumroll.config import load_config
from drumroll.inference.evidence import compute_evidence, importance_evidence
from drumroll.inference.likelihood import OnsetData
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.sampling import SamplerSettings, run_emcee
from drumroll.physics import StickGeometry, bounce_sequence

CONFIG = Path(__file__).resolve().parents[1] / "data" / "table1_d131.toml"
MODELS = ("pendulum", "small-angle", "powerlaw")


def onsets(gap: bool = False) -> OnsetData:
    """The 26 onsets; with ``gap``, bounces 5 and 12 left out (numbered, as an extractor
    reports impacts it did not hear), so that the likelihood indexes the model's impacts."""
    stick = StickGeometry("cylinder-cone", 0.348, 0.06, 0.0075)
    b = bounce_sequence("pendulum", alpha=0.88, pivot=0.131, height=0.08, stick=stick,
                        n_flights=25)
    rng = np.random.default_rng(0)
    times = 1.234 + b.impacts[0] + rng.normal(0, 1e-4, 26)
    if not gap:
        return OnsetData.from_arrays(times)
    keep = np.setdiff1d(np.arange(26), [5, 12])
    return OnsetData.from_arrays(times[keep], None, keep)


def per_call(lp: LogPosterior, points: np.ndarray) -> dict[str, float]:
    """µs per call, the best of 3 repeats."""
    def best(fn, number):
        return min(timeit.repeat(fn, number=number, repeat=3)) / number * 1e6
    out = {"1 point": best(lambda: lp(points[0]), 2000)}  # (ndim,): the float path
    out.update({f"batch{n}": best(lambda n=n: lp(points[:n]), 2000 if n < 64 else 500)
                for n in (1, 16, 64)})
    out["one-point like"] = best(lambda: lp.log_likelihood_one(points[0]), 2000)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="per-call costs only")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--gap", action="store_true",
                        help="bounces 5 and 12 missing from the onsets")
    args = parser.parse_args()
    config, data = load_config(CONFIG), onsets(args.gap)
    print(f"{'model':12s} {'1 point':>8s} {'batch1':>8s} {'batch16':>8s} {'batch64':>8s} "
          f"{'1-pt like':>9s}")
    posteriors = {}
    for model in MODELS:
        lp = posteriors[model] = LogPosterior.build(config, model, data)
        # Points near the posterior: the usual case inside a sampler.
        x = lp.space.sample_prior(np.random.default_rng(1), 4000)
        values = lp(x)
        points = x[np.argsort(values)[::-1][:64]]
        cost = per_call(lp, points)
        print(f"{model:12s} " + " ".join(f"{v:7.0f}µ" for v in cost.values()))
    print("(µs per call; '1 point' is a (ndim,) call, 'batch1' a (1, ndim) one)")
    if args.quick:
        return
    print(f"\n{'model':12s} {'steps':>6s} {'tau_max':>7s} {'s':>6s} {'steps/s':>8s} "
          f"{'ESS(α)':>7s} {'ESS(α)/s':>9s} conv | {'dynesty calls':>13s} {'s':>6s} "
          f"{'ln Z':>16s} | {'IS ln Z':>16s} {'IS ESS':>7s}")
    for model, lp in posteriors.items():
        t = time.perf_counter()
        chain = run_emcee(lp, SamplerSettings(seed=args.seed))
        emcee_s = time.perf_counter() - t
        ess = float(az.ess(chain.samples[..., lp.space.names.index("alpha")], method="bulk"))
        t = time.perf_counter()
        ev = compute_evidence(lp, chain.samples, seed=args.seed)
        dyn_s = time.perf_counter() - t
        check = importance_evidence(lp, chain.samples, np.random.default_rng(args.seed))
        print(f"{model:12s} {chain.n_steps:6d} {np.max(chain.tau):7.1f} {emcee_s:6.1f} "
              f"{chain.n_steps / emcee_s:8.0f} {ess:7.0f} {ess / emcee_s:9.0f} "
              f"{'yes ' if chain.converged else 'NO  '} | {ev.n_calls:13,d} {dyn_s:6.1f} "
              f"{ev.log_z:9.3f}±{ev.log_z_err:.3f} | {check.log_z:9.3f}±{check.log_z_err:.3f} "
              f"{check.ess:7.0f}")


if __name__ == "__main__":
    main()
