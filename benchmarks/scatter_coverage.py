"""Coverage of α and t_B when the restitution scatters, depends on speed, or the impacts last.

Power-law rolls of 16 onsets (α ~ U(0.85, 0.93), t_B ~ U(0.2, 0.3) s, 0.1 ms timing noise) whose
restitution scatters, α_k = α(v_k) e^{ε_k} with ε_k ~ N(0, s²) and 1 − α(v) = (1 − α)(v/v₁)^p
(p = 0: constant), each impact holding the bouncer for a contact time τ_c, each fitted by
``estimate``: with a constant α, with ``restitution_scatter`` in the priors (marginalised,
:mod:`drumroll.inference.scatter`), and, where the truth has it, with the speed law
(``powerlaw/speed``, scatter too); every fit samples the contact time, as ``estimate`` does
by default.
Prints, per fit and parameter, the share of 90 % intervals that cover the truth (with the
binomial 99 % band for that many rolls), the spread of (mean − truth) / sd (1 for honest error
bars) and its mean, and the share of rolls whose fit the posterior predictive check of
:mod:`drumroll.inference.adequacy` calls inadequate (the warning ``estimate`` gives before
any number): a fit whose bars are too narrow should say so.

``--noise student-t`` draws the timing noise from a t with 4 degrees of freedom (scale
0.1 ms) and fits it so (the bundled configs' noise: the scatter's walk and T0 then
integrated out by Laplace's method).

Usage: ``python benchmarks/scatter_coverage.py [--rolls 100] [--scatter 0.005]
[--exponent 0.2] [--contact-ms 1] [--noise student-t] [--seed 1000] [--workers 2]
[--fits scatter,speed]`` (about
5 s per roll and fit on one core under Gaussian noise, 20-30 s under Student-t).
"""

from __future__ import annotations

import argparse
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from scipy.stats import binom

import drumroll
from drumroll.config import parse_config

PRIORS = {"alpha": {"dist": "uniform", "low": 0.5, "high": 1.0},
          "t_b": {"dist": "uniform", "low": 0.01, "high": 2.0},
          "jitter_ms": {"dist": "loguniform", "low": 0.01, "high": 10}}
SCATTER_PRIOR = {"dist": "halfnormal", "sigma": 0.02}


def configs(exponent: float, noise: str = "gaussian", only: tuple[str, ...] = ()) -> dict:
    """The constant-α and the scattering fit, and the speed law's where the truth has it.
    Every fit samples the contact time, as ``estimate`` does by default (``contact_ms`` ~
    U(0, 3 ms)), whatever the truth's."""
    base = {"model": "powerlaw", "compare": [], "sampler": {"evidence": False, "workers": 1},
            "likelihood": {"noise": noise}}
    scatter = {**PRIORS, "restitution_scatter": SCATTER_PRIOR}
    fits = {"constant": parse_config({**base, "priors": PRIORS}),
            "scatter": parse_config({**base, "priors": scatter})}
    if exponent:
        fits["speed"] = parse_config({**base, "model": "powerlaw/speed", "priors": scatter})
    return {name: fit for name, fit in fits.items() if not only or name in only}


def roll(rng: np.random.Generator, scatter: float, exponent: float = 0.0,
         contact_ms: float = 0.0, n: int = 16, noise: str = "gaussian"
         ) -> tuple[np.ndarray, float, float]:
    """Onset times of one roll, and its α and t_B (the rule written out bounce by bounce,
    independently of :mod:`drumroll.physics.restitution`)."""
    alpha, t_b = rng.uniform(0.85, 0.93), rng.uniform(0.2, 0.3)
    eps = rng.normal(0.0, scatter, n - 1)
    u, before = np.empty(n - 1), 0.0
    for k in range(n - 1):
        before = u[k] = before + np.log(1.0 - (1.0 - alpha) * np.exp(exponent * before)) + eps[k]
    impacts = np.concatenate(([0.0], np.cumsum(t_b * np.exp(u)))) + 1e-3 * contact_ms * np.arange(n)
    timing = rng.normal(0, 1e-4, n) if noise == "gaussian" else 1e-4 * rng.standard_t(4.0, n)
    return 0.5 + impacts + timing, alpha, t_b


def fit_roll(i: int, args: argparse.Namespace) -> tuple[float, float, dict]:
    """Roll ``i``'s α and t_B, and every fit's (mean, sd, HDI) of them and adequacy flag."""
    times, alpha, t_b = roll(np.random.default_rng(args.seed + i), args.scatter,
                             args.exponent, args.contact_ms, noise=args.noise)
    out = {}
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "roll.csv"
        path.write_text("time_s\n" + "".join(f"{t:.9f}\n" for t in times))
        for name, config in configs(args.exponent, args.noise, args.fits).items():
            summary = drumroll.estimate(path, config).summary
            parameters = summary.parameters
            out[name] = ([(parameters[q].mean, parameters[q].sd, parameters[q].hdi_low,
                           parameters[q].hdi_high) for q in ("alpha", "t_b")],
                         summary.models[config.model].adequacy.adequate is False)
    return alpha, t_b, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rolls", type=int, default=100)
    ap.add_argument("--scatter", type=float, default=0.005)
    ap.add_argument("--exponent", type=float, default=0.0, help="the truth's speed-law p")
    ap.add_argument("--contact-ms", type=float, default=0.0, help="the truth's contact time")
    ap.add_argument("--noise", choices=("gaussian", "student-t"), default="gaussian")
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--workers", type=int, default=1, help="rolls fitted side by side")
    ap.add_argument("--fits", type=lambda text: tuple(text.split(",")), default=(),
                    help="only these fits, comma-separated (constant, scatter, speed; "
                    "default all)")
    args = ap.parse_args()
    fits = configs(args.exponent, args.noise, args.fits)
    found = {(f, q): [] for f in fits for q in ("alpha", "t_b")}
    truths = {"alpha": [], "t_b": []}
    flagged: dict[str, list[bool]] = {f: [] for f in fits}
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(fit_roll, range(args.rolls), [args] * args.rolls))
    for alpha, t_b, out in results:
        truths["alpha"].append(alpha)
        truths["t_b"].append(t_b)
        for name, (rows, bad) in out.items():
            flagged[name].append(bad)
            for q, row in zip(("alpha", "t_b"), rows, strict=True):
                found[name, q].append(row)
    n = args.rolls
    lo, hi = binom.ppf(0.005, n, 0.9) / n, binom.ppf(0.995, n, 0.9) / n
    print(f"{n} rolls, scatter {args.scatter:g}, exponent {args.exponent:g}, contact "
          f"{args.contact_ms:g} ms, {args.noise} noise; 90 % coverage's binomial 99 % band "
          f"[{lo:.2f}, {hi:.2f}]")
    print(f"{'fit':9s} {'param':6s} {'coverage':>8s} {'spread of z':>11s} {'mean z':>7s} "
          f"{'flagged':>8s}")
    for (name, q), rows in found.items():
        v, truth = np.array(rows), np.array(truths[q])
        cover = np.mean((v[:, 2] < truth) & (truth < v[:, 3]))
        z = (v[:, 0] - truth) / v[:, 1]
        print(f"{name:9s} {q:6s} {cover:8.2f} {np.std(z):11.2f} {np.mean(z):+7.2f} "
              f"{np.mean(flagged[name]):8.2f}")


if __name__ == "__main__":
    main()
