"""``drumroll calibrate CONFIG.toml``: simulation-based calibration of ``estimate`` on the
config's model (Talts et al. 2018): rank histograms, coverage, z-scores, contraction."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from drumroll.cli.arguments import at_least, non_negative_int, positive_int
from drumroll.cli.progress import Progress


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``calibrate`` subcommand."""
    parser = subparsers.add_parser(
        "calibrate", help="simulation-based calibration: are the error bars honest?",
        description="Draw parameters from the config's priors, simulate rolls through its "
        "model and noise, fit each as `estimate` does, and report per parameter the rank "
        "histogram (Talts et al. 2018), the 50 % and 90 % coverage, the mean z-score and "
        "the contraction.")
    parser.add_argument("config", metavar="CONFIG.toml", help="config with the model, its "
                        "priors and noise (and, for --audio, the [simulate] sound)")
    parser.add_argument("--n", type=positive_int, default=200, metavar="N",
                        help="simulations (default 200)")
    parser.add_argument("--onsets", type=at_least(4), metavar="K",
                        help="onsets per simulated roll (default 16, the longest roll of the "
                        "paper's bundled set-ups)")
    parser.add_argument("--audio", action="store_true",
                        help="also render each roll as a recording, find its onsets with the "
                        "extractor and fit them: how the extractor changes the coverage")
    parser.add_argument("-o", "--out", type=Path, metavar="DIR",
                        help="output folder (default: ./<config stem>-calibrate/)")
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="seed of every simulation (default 0)")
    parser.add_argument("--workers", type=positive_int, metavar="N",
                        help="simulations fitted side by side (default: the cores)")
    parser.add_argument("--dask", metavar="ADDRESS",
                        help="run on a Dask cluster, e.g. tcp://scheduler:8786 (needs the "
                        "'dask' extra)")
    parser.add_argument("--force", action="store_true", help="overwrite existing outputs")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``calibrate``: check the config and the output folder, simulate and fit, write."""
    from drumroll.calibration.run import DEFAULT_ONSETS, calibrate, check_calibration
    from drumroll.config import load_config
    from drumroll.reporting.calibration_report import (
        CALIBRATION_FILES,
        check_calibration_outputs,
        headline_text,
        write_calibration,
    )

    config = load_config(args.config)
    out_dir = args.out or Path(f"{Path(args.config).stem}-calibrate")
    check_calibration_outputs(out_dir, overwrite=args.force)
    n_onsets = DEFAULT_ONSETS if args.onsets is None else args.onsets
    check_calibration(config, args.n, n_onsets, args.audio)
    # A bar of the simulations on a terminal, lines of news on a pipe, nothing with --quiet.
    progress = Progress(quiet=args.quiet)
    options = {"n": args.n, "n_onsets": n_onsets, "seed": args.seed, "audio": args.audio,
               "workers": args.workers, "progress": progress}
    with contextlib.ExitStack() as stack:
        if args.dask:
            from drumroll.cli.table import dask_executor

            options["executor"] = stack.enter_context(dask_executor(args.dask))
        result = calibrate(config, **options)
    with progress.stage(f"writing {out_dir}"):
        write_calibration(result, out_dir, overwrite=args.force)
    print(headline_text(result))
    print(f"\nresults in {out_dir}/ ({', '.join(CALIBRATION_FILES.values())})")
    # A parameter that fails is a finding, said in the headline, not an error of the run.
    return 0



def main(argv: list[str] | None = None) -> int:
    """``python -m drumroll.cli.calibrate CONFIG.toml …``: the command without loading the
    other subcommands."""
    from drumroll.cli.main import run_cli

    def make_parser() -> argparse.ArgumentParser:
        parser = argparse.ArgumentParser(prog="drumroll calibrate")
        register(parser.add_subparsers(dest="command", required=True))
        return parser

    return run_cli(make_parser, ["calibrate", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
