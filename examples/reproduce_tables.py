"""Regenerate the paper's Tables 1 and 2, the drumhead-tension comparison and Figure 5.

Runs ``examples/table1.toml``, ``examples/table2.toml`` and ``examples/tension.toml`` over the
bundled simulated recordings in ``data/`` and writes to ``examples/output/``:

* ``table1.md``, ``table2.md``, ``tension.md``: the tables, rounded like the paper, each with
  its HTML page beside it (``table1.html``, …: the same table, its notes and its panel of
  Figure 5 embedded; it opens offline in any browser and prints as it is);
* ``figure5.png``: bounce-duration series, one panel per set of runs (pivot | height |
  drumhead tension), each with its posterior median and 90 % band;
* ``truth_check.md``: each fitted α and t_B against the recording's known truth;
* ``joint.md``: ``drumroll table examples/joint.toml``, one α fitted jointly for two
  recordings of the same set-up, with the χ² test of the separate fits;
* ``calibrate/``: ``drumroll calibrate data/table2_h80.toml --n 200``, the simulation-based
  calibration of the exact pendulum with the paper's priors (issue 14's acceptance), and
  ``calibrate-audio/``, the same with ``--audio``: each roll rendered, heard by the
  extractor and fitted again (about 5 and 25 minutes on two cores; ``--skip-calibration``
  leaves them as they are).

Results are cached in ``examples/.drumroll-cache/`` (a second run takes about a second).

Usage::

    python examples/reproduce_tables.py [--workers N] [--skip-calibration]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import drumroll
from drumroll.fileio import write_text, write_together
from drumroll.reporting.calibration_report import headline_text, write_calibration
from drumroll.reporting.document import Figure, Paragraph
from drumroll.reporting.figure5 import plot_figure5
from drumroll.reporting.markdown import render_markdown
from drumroll.reporting.numbers import format_value_error
from drumroll.reporting.report_files import document_writers
from drumroll.table import load_runs, run_table
from drumroll.table.formatting import (
    FIGURE_CAPTION,
    FIGURE_NOTE,
    format_table,
    table_document,
)
from drumroll.table.joint import joint_table
from drumroll.table.plot import panels, table_png

HERE = Path(__file__).resolve().parent
OUTPUT = HERE / "output"
TABLES = ("table1", "table2", "tension")
#: The paper's numbers, for the comparison under each table.
PAPER = {
    "table1": "Paper, Table 1: d = 110/131/152 ± 2 mm; computed t_B = 0.22 ± 0.01, "
              "0.24 ± 0.01, 0.30 ± 0.02 s; fitted t_B = 0.21 ± 0.01, 0.26 ± 0.01, "
              "0.30 ± 0.02 s; α = 0.86, 0.88, 0.84 (± 0.01).",
    "table2": "Paper, Table 2: h = 50/80/110 ± 3 mm; computed t_B = 0.20 ± 0.01, "
              "0.25 ± 0.01, 0.29 ± 0.01 s; fitted t_B = 0.20 ± 0.01, 0.24 ± 0.01, "
              "0.29 ± 0.01 s; α = 0.90, 0.90, 0.89 (± 0.01).",
    "tension": "Paper: α = 0.860 ± 0.005 (soft drumhead) and 0.899 ± 0.002 (hard).",
}


def truth_rows(name: str, result) -> list[str]:
    """``| run | truth α | fitted α | fitted − truth | truth t_B | fitted t_B |`` lines."""
    lines = []
    for run, row in zip(result.runs.runs, result.rows, strict=True):
        truth_file = run.source.with_name(run.source.stem + ".truth.json")
        if not truth_file.exists():
            continue
        truth = json.loads(truth_file.read_text())
        alpha, t_b = truth["simulate"]["alpha"], truth["physics"]["t_b"]
        fit_a, fit_t = row.alpha, row.fitted_t_b
        lines.append(
            f"| {name}: {run.label} | {alpha:g} | "
            f"{format_value_error(fit_a.value, fit_a.err)} | "
            f"{fit_a.value - alpha:+.4f} ({(fit_a.value - alpha) / fit_a.err:+.1f} σ) "
            f"| {t_b:.4f} | {format_value_error(fit_t.value, fit_t.err)} | "
            f"{row.summary.n_onsets} of {len(truth['impact_times_s'])} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=None, help="parallel runs (cores)")
    parser.add_argument("--skip-calibration", action="store_true",
                        help="do not run the calibrations (calibrate/, calibrate-audio/)")
    args = parser.parse_args()
    OUTPUT.mkdir(exist_ok=True)
    all_panels = []
    truth = ["| run | true α | fitted α | fitted − true | true t_B (s) | fitted t_B (s) | "
             "onsets found |", "|---|---|---|---|---|---|---|"]
    for name in TABLES:
        runs = load_runs(HERE / f"{name}.toml")
        result = run_table(runs, workers=args.workers, progress=print)
        figure = Figure(FIGURE_CAPTION, FIGURE_NOTE, png=table_png(result))
        document = table_document(result, figure).extended(Paragraph((PAPER[name],)))
        write_together(document_writers(OUTPUT / f"{name}.md", document), overwrite=True)
        print(render_markdown(document, OUTPUT))
        all_panels += panels(result)
        truth += truth_rows(name, result)
    plot_figure5(all_panels, OUTPUT / "figure5.png", overwrite=True,
                 title="Figure 5: bounce duration series (simulated recordings; data, "
                 "exact-pendulum posterior median and 90 % band)")
    check = ("**Fits against the known truth of the simulated recordings**\n\n"
             + "\n".join(truth) + "\n")
    write_text(OUTPUT / "truth_check.md", check, overwrite=True)
    print(check)
    runs = load_runs(HERE / "joint.toml")
    result = run_table(runs, workers=args.workers, progress=print)
    result.joint = joint_table(runs, result)
    joint = format_table(result, "markdown")
    write_text(OUTPUT / "joint.md", joint, overwrite=True)
    print(joint)
    if not args.skip_calibration:
        calibrate(args.workers)
    print(f"written to {OUTPUT}")


def calibrate(workers: int | None) -> None:
    """``drumroll calibrate data/table2_h80.toml --n 200`` into ``calibrate/``, and with
    ``--audio`` into ``calibrate-audio/`` (seed 0, as the command's default)."""
    here = Path.cwd()
    os.chdir(HERE.parent)  # the outputs name the config as data/table2_h80.toml
    try:
        for folder, audio in (("calibrate", False), ("calibrate-audio", True)):
            result = drumroll.calibrate(Path("data/table2_h80.toml"), n=200, audio=audio,
                                        workers=workers, progress=print)
            write_calibration(result, OUTPUT / folder, overwrite=True)
            print(headline_text(result))
    finally:
        os.chdir(here)


if __name__ == "__main__":
    main()
