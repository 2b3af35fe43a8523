"""What a notebook shows of a result: its headline, its main table and its key figure.

The objects the Python API returns display themselves through these functions
(``_repr_html_`` and ``_repr_markdown_``): an estimate (:class:`drumroll.pipeline.Result`),
a table (:class:`drumroll.table.execute.TableResult`), an onset table
(:class:`drumroll.onsets.table.OnsetTable`) and the predictions of ``drumroll.predict``
(:class:`drumroll.inference.prior_predictive.Predictions`). Each display is a
:class:`~drumroll.reporting.document.Document` built from the same sections as the
reports, rendered by :func:`~drumroll.reporting.html.render_fragment` (figure embedded) or
:func:`~drumroll.reporting.markdown.render_markdown` (no figure: Markdown cannot embed one
without a file, and a notebook asks for every format of each output it shows, so the
Markdown is kept cheap).

:func:`estimate_figure` gives any figure of an estimate as a
:class:`matplotlib.figure.Figure`, which a notebook shows inline.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from drumroll.errors import DrumrollError
from drumroll.quantities import DERIVED
from drumroll.reporting.document import (
    Block,
    Content,
    Document,
    Figure,
    Heading,
    Paragraph,
    Table,
    TableNote,
    number,
    pointer,
)
from drumroll.reporting.figures import FIGURES
from drumroll.reporting.html import render_fragment
from drumroll.reporting.markdown import render_markdown
from drumroll.reporting.numbers import value_error_number
from drumroll.reporting.plot_style import model_name, png_bytes
from drumroll.reporting.report import lead, parameter_table, report_title

__all__ = ["MAX_ONSET_ROWS", "estimate_display", "estimate_figure", "onsets_display",
           "predictions_display", "table_display", "to_html", "to_markdown"]

#: Onsets listed in an onset table's display (the rest are counted).
MAX_ONSET_ROWS = 40
#: The figure an estimate's display shows.
KEY_FIGURE = "bounce_series"


def to_html(document: Document) -> str:
    """A display as HTML (``_repr_html_``)."""
    return render_fragment(document)


def to_markdown(document: Document) -> str:
    """A display as Markdown (``_repr_markdown_``)."""
    return render_markdown(document)


# -- estimate -------------------------------------------------------------------------------
def estimate_figure(result: Any, name: str = KEY_FIGURE):
    """Figure ``name`` of an estimate (a key of
    :data:`~drumroll.reporting.figures.FIGURES`: ``onsets``, ``bounce_series``,
    ``residuals``, ``comparison``, ``corner``, ``trace``) as a
    :class:`matplotlib.figure.Figure`, the one ``drumroll estimate`` writes.

    Raises
    ------
    drumroll.errors.DrumrollError
        An unknown name, or a figure that does not apply (``onsets`` of onsets read from a
        file, ``comparison`` of one model).
    """
    from drumroll.reporting.outputs import figure_inputs

    if name not in FIGURES:
        raise DrumrollError(f"no figure {name!r}; the figures are {', '.join(FIGURES)}")
    inputs = figure_inputs(result)
    if not FIGURES[name].applies(inputs):
        why = ("the onsets came from a file, not a recording" if name == "onsets"
               else "only one model was fitted")
        raise DrumrollError(f"figure {name!r} does not apply to this estimate: {why}")
    return FIGURES[name].build(inputs)


def estimate_display(result: Any, *, figure: bool = True) -> Document:
    """An estimate's display: the report's opening (notes and warnings, then the headline),
    its parameter table and, with ``figure``, its bounce series."""
    summary = result.summary
    blocks: list[Block] = [*lead(summary),
                           Heading(2, (f"Parameters ({model_name(summary.model)})",)),
                           *parameter_table(summary.parameters, summary.model,
                                            summary.diagnostics.get(summary.model))]
    if figure:
        spec = FIGURES[KEY_FIGURE]
        blocks.append(Figure(spec.caption, spec.note,
                             png=png_bytes(estimate_figure(result, KEY_FIGURE))))
    names = ", ".join(f'"{key}"' for key in FIGURES)
    blocks.append(Paragraph((f"Every figure: result.figure(name), name one of {names}; "
                             "result.summary.to_json() holds every number.",)))
    return Document(report_title(summary), tuple(blocks))


# -- table ----------------------------------------------------------------------------------
def table_display(result: Any, *, figure: bool = True) -> Document:
    """A table's display: the table as ``drumroll table`` writes it and, with ``figure``,
    its Figure 5."""
    from drumroll.table.formatting import FIGURE_CAPTION, FIGURE_NOTE, table_document
    from drumroll.table.plot import table_png

    shown = Figure(FIGURE_CAPTION, FIGURE_NOTE, png=table_png(result)) \
        if figure and result.rows else None
    return table_document(result, shown)


# -- onset table ----------------------------------------------------------------------------
def _ms(value: float, decimals: int = 3) -> Content:
    return ("—",) if not math.isfinite(value) else (number(value, f"{value:.{decimals}f}"),)


def onsets_display(table: Any, *, figure: bool = True) -> Document:
    """An onset table's display: what was found, the onsets (the first
    :data:`MAX_ONSET_ROWS`), and, with ``figure``, the flight times on a log axis."""
    source = Path(table.source).name if table.source else "the recording"
    title = f"Onsets of {source}"
    blocks: list[Block] = [Heading(3, (title,)), Paragraph((table.describe() + ".",))]
    if len(table):
        several = len(table.rolls) > 1
        header: tuple[Content, ...] = (("k",), *((("roll",),) if several else ()),
                                       ("time (s)",), ("interval (ms)",), ("σ (ms)",),
                                       ("SNR (dB)",))
        rows = []
        interval = table.interval_s * 1e3
        for i in range(min(len(table), MAX_ONSET_ROWS)):
            row: tuple[Content, ...] = (
                (number(int(table.bounce[i]), f"{int(table.bounce[i])}"),),
                *(((number(int(table.roll[i]), f"{int(table.roll[i])}"),),) if several
                  else ()),
                (number(table.time_s[i], f"{table.time_s[i]:.6f}"),), _ms(interval[i]),
                _ms(table.sigma_s[i] * 1e3), _ms(table.snr_db[i], 1))
            rows.append(row)
        notes = () if len(table) <= MAX_ONSET_ROWS else (TableNote((
            f"… and {len(table) - MAX_ONSET_ROWS} more onsets (table.to_csv() lists them "
            "all).",)),)
        blocks.append(Table(header, tuple(rows), ("right",) * len(header), notes=notes))
        if figure:
            from drumroll.reporting.onset_plot import draw_flight_times

            blocks.append(Figure("Flight times", "Each flight between consecutive bounces; "
                                 "a drumroll is close to a straight line on this log axis.",
                                 png=png_bytes(draw_flight_times(table))))
    return Document(title, tuple(blocks))


# -- predictions ----------------------------------------------------------------------------
def predictions_display(predictions: Mapping[str, Any], *, figure: bool = True) -> Document:
    """The display of ``drumroll.predict``'s predictions (model → Prediction): each derived
    quantity's mean ± sd per model (numbers pointing into ``predict --json``'s document) and,
    with ``figure``, the predicted flights."""
    models = list(predictions)
    summaries = {m: predictions[m].summary() for m in models}
    draws = {predictions[m].n_draws for m in models}
    title = "Predicted from the priors"
    blocks: list[Block] = [Heading(3, (title,)), Paragraph((
        f"The priors propagated through {', '.join(model_name(m) for m in models)} "
        f"({', '.join(map(str, sorted(draws)))} draws); mean ± sd.",))]
    header = (("quantity",), *((model_name(m),) for m in models))
    rows = []
    for key, quantity in DERIVED.items():
        if not any(key in summaries[m] for m in models):
            continue
        label = quantity.plain + (f" ({quantity.unit})" if quantity.unit else "")
        cells: list[Content] = [(label,)]
        for m in models:
            entry = summaries[m].get(key)
            cells.append(("—",) if entry is None else (value_error_number(
                entry["mean"], entry["sd"], pointer(m, key, "mean"), pointer(m, key, "sd")),))
        rows.append(tuple(cells))
    n_flights = min(len(summaries[m]["flights_s"]["mean"]) for m in models) if models else 0
    for k in range(n_flights):
        cells = [(f"T_{k + 1} (s)",)]
        for m in models:
            flights = summaries[m]["flights_s"]
            cells.append((value_error_number(
                flights["mean"][k], flights["sd"][k], pointer(m, "flights_s", "mean", k),
                pointer(m, "flights_s", "sd", k)),))
        rows.append(tuple(cells))
    dropped = [f"{model_name(m)} {1 - predictions[m].valid_fraction:.1%}" for m in models
               if predictions[m].valid_fraction < 1]
    notes = (TableNote((f"Draws that make no drumroll, dropped: {', '.join(dropped)}.",),
                       warning=True),) if dropped else ()
    blocks.append(Table(header, tuple(rows), (None, *("right",) * len(models)), notes=notes))
    if figure and models:
        from drumroll.reporting.prediction_plot import draw_predicted_flights

        blocks.append(Figure("Predicted flights", "Each model's flight times from the "
                             "priors; the spread is what the measured geometry allows.",
                             png=png_bytes(draw_predicted_flights(predictions))))
    return Document(title, tuple(blocks))
