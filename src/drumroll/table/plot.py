"""Figure 5 of a table: its runs' rows grouped into panels (see :mod:`..reporting.figure5`)."""

from __future__ import annotations

import os
from pathlib import Path

from drumroll.inference.results import Summary
from drumroll.table.execute import TableResult


def panels(result: TableResult) -> list[tuple[str | None, list[tuple[str, Summary]]]]:
    """``(group, [(label, summary), …])`` per group, in the order the groups first appear."""
    out: dict[str | None, list[tuple[str, dict]]] = {}
    for run, row in zip(result.runs.runs, result.rows, strict=True):
        out.setdefault(run.group, []).append((run.label, row.summary))
    return list(out.items())


def draw_table(result: TableResult):
    """Figure 5 of ``result`` as a :class:`matplotlib.figure.Figure`."""
    from drumroll.reporting.figure5 import draw_figure5
    from drumroll.reporting.plot_style import style

    with style():
        return draw_figure5(panels(result), title=result.runs.title)


def table_png(result: TableResult) -> bytes:
    """Figure 5 of ``result`` as the PNG :func:`plot_table` writes, in memory."""
    from drumroll.reporting.plot_style import png_bytes

    return png_bytes(draw_table(result))


def plot_table(result: TableResult, path: str | os.PathLike[str], *,
               overwrite: bool = False) -> Path:
    """Write Figure 5 of ``result`` to ``path`` (PNG, atomically)."""
    from drumroll.reporting.figure5 import plot_figure5

    return plot_figure5(panels(result), path, title=result.runs.title, overwrite=overwrite)
