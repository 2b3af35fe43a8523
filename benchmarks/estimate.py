"""Benchmark of ``estimate``: the README's main command, this code against a named revision.

1. Wall time of ``estimate data/table2_h80.flac --prior data/table2_h80.toml`` (exact pendulum
   compared with small-angle and power law, evidences, every figure), run as a user runs it,
   the working tree and the code of ``--against`` (default be26b5a, checked out into a
   temporary git worktree: nothing is installed, no network) alternately, ``--repeats`` times
   each. Prints both medians, their ratio with the ratios run by run and a bootstrap
   interval over the pairs of runs, and each one's stages (start-up, sampling and
   evidence per model, writing), and α's effective samples and ESS per second.
2. The issue's other targets, the same way: a 6-run ``drumroll table`` (the bundled recordings
   of Tables 1 and 2, no cache), ``drumroll onsets`` on a 4 s recording, ``estimate --help``.
3. Effective samples of α per second: drumroll's sampler against emcee's default stretch move
   given the same number of steps, side by side on the same posterior.

Run: ``python benchmarks/estimate.py [--against REV] [--repeats 3] [--source data/table2_h80.flac]
[--skip-main] [--skip-others] [--skip-peer]``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Iterator
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
#: The code the speed targets are measured against.
BASELINE = "be26b5a"


@contextlib.contextmanager
def worktree(revision: str) -> Iterator[Path]:
    """The code of ``revision`` checked out into a temporary git worktree (removed after)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "--quiet",
                        str(path), revision], check=True)
        try:
            yield path
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                            str(path)], check=False)


def in_tree(path: Path, src: Path) -> Path:
    """``path`` of this checkout as the checkout whose package is at ``src`` has it: each
    version runs the command on its own bundled files, as its users do (a config key renamed
    since is then no error)."""
    try:
        relative = path.relative_to(ROOT)
    except ValueError:
        return path  # not a bundled file: the same for both
    theirs = src.parent / relative
    return theirs if theirs.exists() else path


def _shown(path: Path) -> str:
    """``path`` relative to the checkout when it lies inside it (a user's config may not)."""
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def run_once(src: Path, source: Path, config: Path) -> dict:
    """One run of the main command with the package at ``src``: wall time, the stages the
    progress lines and ``summary.json`` give, and α's summary."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        env = {**os.environ, "PYTHONPATH": str(src)}
        command = [sys.executable, "-m", "drumroll", "estimate", str(in_tree(source, src)),
                   "--prior", str(in_tree(config, src)), "-o", str(out)]
        started = time.perf_counter()
        proc = subprocess.run(command, capture_output=True, text=True, check=False, env=env)
        wall = time.perf_counter() - started
        if proc.returncode != 0:
            raise RuntimeError(f"main command failed ({proc.returncode}) with {src}: "
                               f"{proc.stderr.strip()[-300:]}")
        summary = json.loads((out / "summary.json").read_text())
    done = dict(re.findall(r"^(estimating|writing) .*: done in ([\d.]+) s$", proc.stderr,
                           flags=re.MULTILINE))
    stages = {"start-up": wall - sum(float(v) for v in done.values())}
    stages.update({f"{k} ({'fit' if k == 'estimating' else 'outputs'})": float(v)
                   for k, v in done.items()})
    stages.update({f"  {k}": float(v) for k, v in summary.get("seconds", {}).items()})
    alpha = summary["parameters"]["alpha"]
    return {"wall": wall, "stages": stages, "alpha": alpha, "preferred": summary["preferred"]}


def ratio_interval(ours: np.ndarray, theirs: np.ndarray, level: float = 0.9,
                   resamples: int = 10_000, seed: int = 0) -> tuple[float, float]:
    """The bootstrap interval of median(ours) / median(theirs), the alternating runs resampled
    in pairs (a pair shares the machine's state of the moment: this machine's speed drifts by
    ±10 % within minutes, so one ratio from five runs each moves by ±0.03)."""
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, ours.size, (resamples, ours.size))
    ratios = np.median(ours[picks], axis=1) / np.median(theirs[picks], axis=1)
    return tuple(float(q) for q in np.quantile(ratios, [(1 - level) / 2, (1 + level) / 2]))


def main_command(source: Path, config: Path, repeats: int, against: str,
                 goal: float | None = 0.33) -> None:
    """The main command, this tree and ``against`` alternately; medians and their ratio (and
    the ratio aimed at, if any)."""
    runs: dict[str, list[dict]] = {"this tree": [], against: []}
    with worktree(against) as old:
        trees = {"this tree": ROOT / "src", against: old / "src"}
        for _ in range(repeats):
            for label, src in trees.items():
                runs[label].append(run_once(src, source, config))
    print(f"main command: estimate {_shown(source)} --prior "
          f"{_shown(config)}, {repeats} runs each, alternating, {os.cpu_count()} "
          "cores")
    medians = {label: statistics.median(r["wall"] for r in rs) for label, rs in runs.items()}
    for label, rs in runs.items():
        walls = ", ".join(f"{r['wall']:.1f}" for r in rs)
        print(f"  {label:>12}: median {medians[label]:5.1f} s wall (runs: {walls})")
    ratio = medians["this tree"] / medians[against]
    print(f"  ratio this tree / {against}: {ratio:.2f}"
          + ("" if goal is None else f" (goal <= {goal:.2f})"))
    ours = np.array([r["wall"] for r in runs["this tree"]])
    theirs = np.array([r["wall"] for r in runs[against]])
    low, high = ratio_interval(ours, theirs)
    paired = ours / theirs
    print(f"  run by run (each run of this tree over the {against} run beside it): median "
          f"{np.median(paired):.2f}, {paired.min():.2f}-{paired.max():.2f}; the ratio's 90 % "
          f"bootstrap interval over the pairs {low:.2f}-{high:.2f}")
    print(f"\n  stages of the median run (s)      {'this tree':>10} {against:>10}")
    middle = {label: sorted(rs, key=lambda r: r["wall"])[len(rs) // 2]
              for label, rs in runs.items()}
    keys = list(dict.fromkeys(k for r in middle.values() for k in r["stages"]))
    for key in keys:
        cells = [middle[label]["stages"].get(key) for label in runs]
        print(f"  {key:<32} " + " ".join(f"{c:10.2f}" if c is not None else f"{'':>10}"
                                        for c in cells))
    print()
    for label, r in middle.items():
        a = r["alpha"]
        ess_per_s = a["ess_bulk"] / r["wall"]
        print(f"  {label:>12}: α = {a['mean']:.5f} ± {a['sd']:.5f}, ESS bulk {a['ess_bulk']:.0f}"
              f", tail {a.get('ess_tail', float('nan')):.0f}, R-hat {a['r_hat']:.4f}; "
              f"{ess_per_s:.0f} ESS(α) per second of wall time; preferred {r['preferred']}")


#: The six bundled recordings of the paper's Tables 1 and 2, each with its own config.
TABLE_RUNS = ("table1_d110", "table1_d131", "table1_d152", "table2_h50", "table2_h80",
              "table2_h110")


def six_run_table(folder: Path, src: Path = ROOT / "src") -> Path:
    """A runs file of :data:`TABLE_RUNS` (absolute paths of the bundled files of the checkout
    whose package is at ``src``) in ``folder``."""
    lines = ['title = "Tables 1 and 2: six runs"', ""]
    data = src.parent / "data"
    for name in TABLE_RUNS:
        lines += ["[[run]]", f'label = "{name}"', f'source = "{data / name}.flac"',
                  f'config = "{data / name}.toml"', ""]
    path = folder / f"six_runs_{src.parent.name}.toml"
    path.write_text("\n".join(lines))
    return path


def timed(src: Path, arguments: list[str]) -> tuple[float, str]:
    """Wall time of ``python -m drumroll ARGUMENTS`` with the package at ``src``, and its
    standard output (a failure raises)."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    started = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "drumroll", *arguments], capture_output=True,
                          text=True, check=False, env=env)
    wall = time.perf_counter() - started
    if proc.returncode != 0:
        raise RuntimeError(f"drumroll {' '.join(arguments)} failed ({proc.returncode}) with "
                           f"{src}: {proc.stderr.strip()[-300:]}")
    return wall, proc.stdout


def other_commands(repeats: int, against: str) -> None:
    """The issue's other targets, side by side: a 6-run ``drumroll table`` (no cache; goal ≤
    1/3), ``drumroll onsets`` on a 4 s recording (goal ≤ 1/2) and ``estimate --help`` (goal:
    no slower)."""
    with worktree(against) as old, tempfile.TemporaryDirectory() as tmp:
        trees = {"this tree": ROOT / "src", against: old / "src"}
        runs_files = {label: six_run_table(Path(tmp), src) for label, src in trees.items()}
        cases = {
            "table, 6 runs (no cache)": (["table", "{runs}", "--no-cache", "-q"], 1 / 3),
            "onsets, 4 s recording": (["onsets", str(ROOT / "data" / "table2_h80.flac")],
                                      1 / 2),
            "estimate --help": (["estimate", "--help"], 1.0),
        }
        print(f"\nother commands, {repeats} runs each, alternating (median wall, s)")
        print(f"  {'command':<28} {'this tree':>10} {against:>10} {'ratio':>7} {'goal':>6}")
        for name, (arguments, goal) in cases.items():
            walls: dict[str, list[float]] = {label: [] for label in trees}
            outputs: dict[str, str] = {}
            for _ in range(repeats):
                for label, src in trees.items():
                    wall, outputs[label] = timed(src, [str(runs_files[label]) if a == "{runs}"
                                                       else a for a in arguments])
                    walls[label].append(wall)
            medians = {label: statistics.median(w) for label, w in walls.items()}
            ratio = medians["this tree"] / medians[against]
            print(f"  {name:<28} {medians['this tree']:10.2f} {medians[against]:10.2f} "
                  f"{ratio:7.2f} {'≤ ' + format(goal, '.2f') if against == BASELINE else '':>6}")
            if name.startswith("table"):
                for label, text in outputs.items():  # the same numbers?
                    rows = [line for line in text.splitlines() if line.startswith("|")]
                    print(f"    {label}:\n      " + "\n      ".join(rows))


def ess_alpha(chain: np.ndarray) -> float:
    """Bulk ESS of α from a (walkers, draws) array."""
    return float(az.ess(chain, method="bulk"))


def sampler_peer(source: Path, config: Path) -> None:
    cfg = load_config(config)
    data = choose_roll(load_onsets(source)).data  # the roll estimate fits, as it numbers it
    settings = estimate_settings(cfg)  # the config's noise model, as estimate uses
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
    parser.add_argument("--against", default=BASELINE,
                        help=f"git revision to compare with (default {BASELINE})")
    parser.add_argument("--skip-main", action="store_true")
    parser.add_argument("--skip-peer", action="store_true")
    parser.add_argument("--skip-others", action="store_true",
                        help="skip the table, onsets and --help timings")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each version")
    args = parser.parse_args()
    source = args.source.resolve()
    config = (args.config or args.source.with_suffix(".toml")).resolve()
    if not args.skip_main:
        main_command(source, config, args.repeats, args.against,
                     goal=0.33 if args.against == BASELINE else None)
    if not args.skip_others:
        other_commands(args.repeats, args.against)
    if not args.skip_peer:
        sampler_peer(source, config)


if __name__ == "__main__":
    sys.exit(main())
