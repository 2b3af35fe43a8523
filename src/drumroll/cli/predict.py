"""``drumroll predict CONFIG.toml``: the "computed t_B" of the paper's tables."""

from __future__ import annotations

import argparse
import json
import math
import warnings
from typing import TYPE_CHECKING

from drumroll.cli.arguments import at_least, non_negative_int, positive_int
from drumroll.errors import DrumrollWarning
from drumroll.quantities import DERIVED
from drumroll.reporting.numbers import format_value_error

if TYPE_CHECKING:
    from drumroll.inference.prior_predictive import Prediction



def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``predict`` subcommand."""
    parser = subparsers.add_parser(
        "predict", help="propagate the priors through the models (computed t_B)",
        description="Propagate the config's priors (measured geometry with its ±) by Monte "
        "Carlo through the small-angle and exact pendulum models (and the power law when t_b "
        "has a prior), and print t_C, t_B, θ_C, ω_C and the first flight times as mean ± sd.")
    parser.add_argument("config", help="TOML config file")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("-n", "--flights", type=positive_int, default=5, metavar="N",
                        help="number of flight times to print (default 5)")
    parser.add_argument("--draws", type=at_least(2), default=20_000,
                        help="Monte Carlo draws, at least 2 (default 20000)")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="random seed (default 0)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``predict``."""
    # The models and priors (scipy): only when predict runs, not for every command's --help.
    from drumroll.inference.prior_predictive import predict

    predictions = list(predict(args.config, n_flights=args.flights, n_draws=args.draws,
                               seed=args.seed).values())
    for p in predictions:
        if p.invalid_reasons:
            reason = max(p.invalid_reasons, key=p.invalid_reasons.get)
            warnings.warn(f"{p.model}: {1 - p.valid_fraction:.1%} of the draws were dropped: "
                          f"{reason}", DrumrollWarning, stacklevel=1)
        overflowed = _overflowed(p.summary())
        if overflowed:
            warnings.warn(f"{p.model}: {', '.join(overflowed)}: the draws are too large to "
                          "average (the mean or sd overflows); check the priors' ranges and "
                          "units", DrumrollWarning, stacklevel=1)
    if args.json:
        print(json.dumps({p.model: p.summary() for p in predictions}, indent=2))
    else:
        print(_table(predictions, args))
    return 0


def _overflowed(summary: dict) -> list[str]:
    """The quantities of a prediction's ``summary`` whose mean or sd is not a finite
    number, by their printed names."""
    names = [quantity.plain for key, quantity in DERIVED.items() if key in summary
             and not all(math.isfinite(summary[key][k]) for k in ("mean", "sd"))]
    flights = summary["flights_s"]
    names += [f"T_{k}" for k, values in enumerate(zip(flights["mean"], flights["sd"],
                                                      strict=True), 1)
              if not all(math.isfinite(v) for v in values)]
    return names


def _table(predictions: list[Prediction], args: argparse.Namespace) -> str:
    lines = [f"{args.config}: prior propagation, {args.draws} draws (seed {args.seed}); "
             "mean ± sd"]
    for p in predictions:
        lines.append(f"\n{p.model}")
        summary = p.summary()
        for key, quantity in DERIVED.items():
            if key not in summary:
                continue
            mean, sd = summary[key]["mean"], summary[key]["sd"]
            lines.append(f"  {quantity.plain:<10} "
                         f"{format_value_error(mean, sd, unit=quantity.unit)}")
        flights = summary["flights_s"]
        for k, (mean, sd) in enumerate(zip(flights["mean"], flights["sd"], strict=True), 1):
            lines.append(f"  {'T_' + str(k):<10} {format_value_error(mean, sd, unit='s')}")
    return "\n".join(lines)
