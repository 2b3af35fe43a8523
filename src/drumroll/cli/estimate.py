"""``drumroll estimate SOURCE --prior CONFIG.toml`` (also installed as ``estimate``)."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

from drumroll.cli.arguments import non_negative_int, positive_int
from drumroll.cli.progress import Progress
from drumroll.errors import DrumrollError
from drumroll.onsets import ONSET_FILE_SUFFIXES
from drumroll.quantities import QUANTITIES
from drumroll.reporting.numbers import (
    format_value_error,
    model_average_text,
    numbering_average_text,
)

if TYPE_CHECKING:
    from drumroll.pipeline import Result

def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of ``estimate`` (shared by ``drumroll estimate`` and ``estimate``)."""
    parser.add_argument("source", help="recording (WAV, FLAC, OGG, MP3; a phone's .m4a, .3gp, "
                        ".webm; a camera's .mp4 or .mov; …) or onset file (our CSV, Audacity "
                        "labels, one time per line)")
    parser.add_argument("--prior", "--config", dest="config", required=True,
                        metavar="CONFIG.toml", help="config with the model and its priors")
    parser.add_argument("-o", "--out", type=Path, help="output folder (default: "
                        "./<source stem>-estimate/)")
    parser.add_argument("--roll", type=non_negative_int, metavar="N",
                        help="which roll to fit when the recording holds several (0, 1, 2, "
                        "… in time order; default: the longest)")
    parser.add_argument("--stream", type=non_negative_int, metavar="N",
                        help="which audio stream of a video or other file with several (0, 1, "
                        "2, …; default 0, the first)")
    parser.add_argument("--truth", type=Path, help="truth JSON of a simulated recording "
                        "(drawn on the corner plot)")
    parser.add_argument("--seed", type=non_negative_int, help="override [sampler] seed")
    parser.add_argument("--workers", type=positive_int, metavar="N",
                        help="processes fitting models side by side")
    parser.add_argument("--no-evidence", action="store_true",
                        help="skip nested sampling (no Bayes factors; LOO only)")
    parser.add_argument("--force", action="store_true", help="overwrite existing outputs")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    parser.set_defaults(func=run)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``estimate`` subcommand."""
    parser = subparsers.add_parser(
        "estimate", help="posteriors of α, t_B, pivot, release speed, jitter; model comparison",
        description="Estimate the restitution coefficient, fall and rebound times, effective "
        "pivot, release speed and onset jitter from a drumroll recording, with the exact "
        "pendulum compared against its small-angle version and the power law.")
    add_arguments(parser)


def _truths(path: Path | None) -> dict[str, float] | None:
    if path is None:
        return None
    try:
        truth = json.loads(path.read_text())
    except FileNotFoundError:
        raise DrumrollError(f"{path}: no such truth file") from None
    except (OSError, ValueError) as exc:
        raise DrumrollError(f"{path}: not a truth JSON file ({exc})") from None
    sections = [truth.get(name, {}) for name in ("simulate", "physics")] \
        if isinstance(truth, dict) else None
    if sections is None or not all(isinstance(section, dict) for section in sections):
        raise DrumrollError(f"{path}: not a truth file (a JSON object with 'simulate' and "
                            "'physics' objects, as `drumroll simulate --truth` writes)")
    # The truth's values are under the quantities' own keys (drumroll.quantities), as the
    # posterior's are: what the simulation was given, and what its physics made of it.
    given = {**sections[0], **sections[1]}
    return {key: float(given[key]) for key in QUANTITIES
            if isinstance(given.get(key), int | float) and not isinstance(given[key], bool)}


def _apply_overrides(config, args: argparse.Namespace):
    sampler = dict(config.section("sampler", {}))
    if args.seed is not None:
        sampler["seed"] = args.seed
    if args.workers is not None:
        sampler["workers"] = args.workers
    if args.no_evidence:  # the section is parsed already: its value as parsing leaves it
        from drumroll.inference.settings import evidence_mode

        sampler["evidence"] = evidence_mode(False, "--no-evidence")
    config.sections["sampler"] = sampler
    return config


def run(args: argparse.Namespace) -> int:
    """Run ``estimate``: check inputs and outputs first, then sample, then write."""
    # Imported here: the samplers take a second to import, which other commands (and
    # ``--help``) should not pay; the figures' libraries are imported while the models are
    # sampled (by the FigureDrawer, which starts drawing then).
    from drumroll.pipeline import estimate
    from drumroll.reporting.outputs import (
        FigureDrawer,
        check_outputs,
        output_files,
        write_outputs,
    )

    source = Path(args.source)
    if not source.exists():
        raise DrumrollError(f"{source}: no such file")
    if source.is_dir():
        raise DrumrollError(f"{source}: is a directory, expected a recording or onset file")
    from drumroll.config import load_config  # priors and scipy: only when a fit runs

    config = _apply_overrides(load_config(args.config), args)
    truths = _truths(args.truth)
    out_dir = args.out or Path(f"{source.stem}-estimate")
    is_audio = source.suffix.lower() not in ONSET_FILE_SUFFIXES
    if args.stream is not None and not is_audio:
        raise DrumrollError(f"{source}: --stream picks an audio stream of a recording; an onset "
                            "file has none")
    onset_options = {} if args.stream is None else {"stream": args.stream}
    check_outputs(out_dir, output_files(include_onsets_figure=is_audio), overwrite=args.force)
    progress = Progress(quiet=args.quiet)
    # Figures are drawn as soon as their inputs exist, while the estimate goes on.
    with FigureDrawer(out_dir, truths=truths, workers=args.workers) as drawer:
        with progress.stage(f"estimating {', '.join(config.models)} from {source.name}"):
            result = estimate(source, config, roll=args.roll, progress=progress,
                              listener=drawer, **onset_options)
        with progress.stage(f"writing {out_dir}"):
            write_outputs(result, out_dir, overwrite=args.force, truths=truths,
                          workers=args.workers, drawer=drawer)
    print(terminal_table(result))
    print(f"\nresults in {out_dir}/ (report.md, report.html, summary.json, posterior.nc, figures)")
    return 0


def terminal_table(result: Result) -> str:
    """The notes on the onsets (other rolls, missing bounces), then the compact table:
    parameter, mean, sd, interval, R-hat, ESS; then the verdict."""
    summary = result.summary
    parameters = summary.parameters
    hdi = next(iter(parameters.values())).hdi_prob
    lines = [f"note: {note}" for note in summary.notes]
    misfit = summary.misfit
    if misfit:  # before any number: the numbers below describe a model that does not fit
        lines.append(f"warning: {misfit}")
    lines += [f"{summary.model}: {summary.n_onsets} onsets",
              f"{'parameter':<22} {'mean ± sd':>22} {f'{hdi:.0%} interval':>24} "
              f"{'R-hat':>7} {'ESS':>6}"]
    for name, p in parameters.items():
        if p.sd is None or p.mean is None:
            continue
        mean_sd = format_value_error(p.mean, p.sd)
        decimals = mean_sd.split(" ± ")[0]
        places = len(decimals.split(".")[1]) if "." in decimals else 0
        interval = (f"[{p.hdi_low:.{places}f}, {p.hdi_high:.{places}f}]"
                    if p.hdi_low is not None and p.hdi_high is not None else "—")
        r_hat = "—" if p.r_hat is None else f"{p.r_hat:.4f}"
        ess = "—" if p.ess_bulk is None else f"{min(p.ess_bulk, p.ess_tail or math.inf):.0f}"
        lines.append(f"{name:<22} {mean_sd:>22} {interval:>24} {r_hat:>7} {ess:>6}")
    lines += [f"{name} is 0 (absent) with probability {p.probability_zero:.2f}"
              for name, p in parameters.items() if p.probability_zero is not None]
    over_numberings = numbering_average_text(summary.numbering_average)
    if over_numberings:  # the table holds for one numbering; this for all of them
        lines.append(f"over the first onset's numberings: {over_numberings}")
    lines += [f"warning: {warning}" for warning in summary.warnings if warning != misfit]
    lines.append("")
    preferred = summary.preferred
    why = "the model does not describe the onsets" if misfit else "the data cannot tell"
    lines.append(f"preferred: {preferred if preferred else f'none ({why})'}")
    lines.append(f"verdict: {summary.verdict}")
    averaged = model_average_text(summary.model_average)
    if averaged:
        lines.append(f"model-averaged: {averaged}")
    return "\n".join(lines)
