"""drumroll from Python: one recording estimated, then a small table of several recordings.

Run from anywhere: ``python examples/api_example.py``. The table's runs are cached in
``examples/.drumroll-cache/`` (a second run prints the table at once).
"""

from __future__ import annotations

from pathlib import Path

import drumroll
from drumroll.config import parse_config
from drumroll.reporting.numbers import format_value_error
from drumroll.table import format_table, parse_runs, run_table

DATA = Path(__file__).resolve().parents[1] / "data"


def one_recording() -> None:
    """Onsets -> posteriors of the exact pendulum (compared with the small-angle model)."""
    config = parse_config({
        "model": "pendulum", "compare": ["small-angle"],
        "stick": {"shape": "cylinder-cone", "length_mm": 348, "tip_mm": 60, "radius_mm": 7.5},
        "priors": {"alpha": {"dist": "uniform", "low": 0.5, "high": 1.0},
                   "pivot_mm": {"dist": "normal", "mu": 131, "sigma": 2},
                   "height_mm": {"dist": "normal", "mu": 80, "sigma": 3}},
        "sampler": {"evidence": False},
    })
    result = drumroll.estimate(DATA / "table2_h80.flac", config)
    for name in ("alpha", "t_b", "pivot_mm", "height_mm"):
        p = result.parameter(name)
        print(f"{name:>10} = {format_value_error(p.mean, p.sd)}")
    print(f"preferred model: {result.preferred or 'undecided'} ({len(result.onsets)} onsets)")


def small_table() -> None:
    """Two drumhead tensions as a table, built from a dict instead of a RUNS.toml file."""
    runs = parse_runs({
        "title": "Drumhead tension (d = 131 mm, h = 80 mm)",
        "sampler": {"evidence": False},
        "run": [{"label": "soft", "source": str(DATA / "tension_soft.flac"),
                 "config": str(DATA / "tension_soft.toml")},
                {"label": "hard", "source": str(DATA / "tension_hard.flac"),
                 "config": str(DATA / "tension_hard.toml")}],
    }, path=Path(__file__).resolve())
    result = run_table(runs, progress=print)  # in parallel on every core, cached by content
    print(format_table(result, "markdown"))
    soft, hard = (row.alpha for row in result.rows)
    change = hard.value / soft.value - 1
    print(f"alpha rises by {change:.1%} from the soft to the hard drumhead (paper: 4 %)")


if __name__ == "__main__":
    one_recording()
    small_table()
