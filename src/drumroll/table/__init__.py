"""``drumroll table``: the paper's Tables 1–2 and Figure 5 from a folder of recordings.

:func:`load_runs` reads a RUNS.toml (validated before any sampling), :func:`run_table`
estimates its runs in parallel with a content-addressed cache, :func:`format_table` formats the
table (Markdown, CSV, LaTeX, JSON) and :func:`drumroll.table.plot.plot_table` draws Figure 5.
"""

from drumroll.table.execute import TableResult, compute_run, run_table
from drumroll.table.formatting import FORMATS, format_table, table_rows
from drumroll.table.runs import Run, RunsFile, load_runs, parse_runs

__all__ = [
           "FORMATS",
           "Run",
           "RunsFile",
           "TableResult",
           "compute_run",
           "format_table",
           "load_runs",
           "parse_runs",
           "run_table",
           "table_rows",
]
