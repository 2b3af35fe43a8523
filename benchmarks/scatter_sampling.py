"""Benchmark of sampling a restitution that may scatter: this tree against a named revision,
side by side in one run.

The ensemble walks the scatter s as the absolute value of its column (this tree: the density
of z is the posterior mirrored across 0, a bump about 0 where s piles against it) or through
its logarithm (``--against``, default 13c4159, where the walkers spread over several e-folds
towards s = 0). For each posterior, each seed's fit of the config's main model is run in
both trees alternately (``run_emcee`` as ``estimate`` calls it, stopping when every reported
quantity has bulk and tail ESS ≥ 1000 and R-hat < 1.01, in a process of its own with the
other tree's package on its path), and the medians of the steps and seconds are printed with
their ratio, beside the posterior mean and sd of s and α from both (the same posterior,
within Monte Carlo error):

* the README's roll (data/table2_h80.flac, the exact pendulum) with the scatter's half-normal
  prior, under Gaussian noise and under its config's Student-t noise: the scatter piles
  against 0;
* the real ping-pong (data/pingpong.wav, the power law) with the same prior: s = 0.0045,
  well away from 0.

Run: ``python benchmarks/scatter_sampling.py [--against REV] [--seeds 5]`` (about 6 minutes
with five seeds on two cores; the Student-t posterior is the slow one).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from estimate import worktree  # this folder's benchmark

ROOT = Path(__file__).resolve().parents[1]
#: The code before: the scatter walked through its logarithm.
BEFORE = "13c4159"
SCATTER_LINE = 'restitution_scatter = { dist = "halfnormal", sigma = 0.02 }'

#: One fit, run in a process of its own: ``config source model seed`` → JSON on stdout.
RUNNER = """
import json, sys, time, warnings
from dataclasses import replace
from functools import partial
warnings.simplefilter("ignore")
from drumroll.config import load_config
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.sampling import run_emcee
from drumroll.inference.settings import estimate_settings
from drumroll.pipeline import choose_roll, load_onsets, reported_draws
config, source, model, seed = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
cfg = load_config(config)
settings = estimate_settings(cfg)
lp = LogPosterior.build(cfg, model, choose_roll(load_onsets(source)).data, settings.noise,
                        settings.nu)
started = time.perf_counter()
chain = run_emcee(lp, replace(settings.sampler, seed=seed),
                  reported=partial(reported_draws, lp, seed))
seconds = time.perf_counter() - started
out = {"steps": int(chain.n_steps), "seconds": seconds}
for name in ("restitution_scatter", "alpha"):
    values = chain.samples[..., lp.space.names.index(name)].ravel()
    out[name] = [float(values.mean()), float(values.std())]
print(json.dumps(out))
"""


def posteriors(folder: Path) -> dict[str, tuple[Path, Path, str]]:
    """name → (config, recording, model): the bundled configs with the scatter's line added
    (the README's roll with only its main model)."""
    out = {}
    h80 = (ROOT / "data" / "table2_h80.toml").read_text()
    h80 = h80.replace('compare = ["small-angle", "powerlaw"]', "compare = []")
    h80 = h80.replace("[priors]\n", f"[priors]\n{SCATTER_LINE}\n", 1)
    gaussian = h80.replace('noise = "student-t"\nnu = 4', 'noise = "gaussian"')
    ping = (ROOT / "data" / "pingpong.toml").read_text()
    ping = ping.replace("[priors]\n", f"[priors]\n{SCATTER_LINE}\n", 1)
    for name, text, source, model in (
            ("table2_h80, Gaussian noise", gaussian, "table2_h80.flac", "pendulum"),
            ("table2_h80, Student-t noise", h80, "table2_h80.flac", "pendulum"),
            ("real ping-pong, Gaussian noise", ping, "pingpong.wav", "powerlaw")):
        path = folder / f"{len(out)}.toml"
        path.write_text(text)
        out[name] = (path, ROOT / "data" / source, model)
    return out


def fit(src: Path, config: Path, source: Path, model: str, seed: int) -> dict:
    """One fit with the package at ``src``."""
    env = dict(os.environ, PYTHONPATH=str(src), OPENBLAS_NUM_THREADS="1")
    done = subprocess.run([sys.executable, "-c", RUNNER, str(config), str(source), model,
                           str(seed)], env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", default=BEFORE, help="the revision compared with")
    parser.add_argument("--seeds", type=int, default=5, help="fits per posterior and tree")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp, worktree(args.against) as theirs:
        trees = {"this tree": ROOT / "src", args.against: theirs / "src"}
        print(f"run_emcee on each posterior, seeds 0-{args.seeds - 1}, trees alternately; "
              "medians (steps, seconds), their ratio (this tree / the other), and the "
              "posterior mean ± sd of s and α")
        for name, (config, source, model) in posteriors(Path(tmp)).items():
            runs: dict[str, list[dict]] = {tree: [] for tree in trees}
            for seed in range(args.seeds):
                for tree, src in trees.items():
                    runs[tree].append(fit(src, config, source, model, seed))
            print(f"\n{name} ({model}, {source.name})")
            medians = {}
            for tree, fits in runs.items():
                steps = statistics.median(f["steps"] for f in fits)
                seconds = statistics.median(f["seconds"] for f in fits)
                medians[tree] = (steps, seconds)
                s = statistics.fmean(f["restitution_scatter"][0] for f in fits)
                s_sd = statistics.fmean(f["restitution_scatter"][1] for f in fits)
                a = statistics.fmean(f["alpha"][0] for f in fits)
                a_sd = statistics.fmean(f["alpha"][1] for f in fits)
                print(f"  {tree:>10s}: {steps:6.0f} steps {seconds:6.1f} s (runs: "
                      f"{', '.join(str(f['steps']) for f in fits)} steps); s {s:.5f} ± "
                      f"{s_sd:.5f}, alpha {a:.5f} ± {a_sd:.5f}")
            (ours_steps, ours_s), (their_steps, their_s) = medians.values()
            print(f"  ratio this tree / {args.against}: steps {ours_steps / their_steps:.2f}, "
                  f"seconds {ours_s / their_s:.2f}")


if __name__ == "__main__":
    main()
