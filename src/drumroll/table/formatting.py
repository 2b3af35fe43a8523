"""The table as Markdown, HTML, CSV, LaTeX (booktabs + siunitx) or JSON, rounded like the
paper.

Every ``value ± err`` is rounded by :func:`drumroll.reporting.numbers.format_value_error`: the
error to one or two significant digits, the value to match (``0.22 ± 0.01``). The Markdown
and the HTML page are one :class:`~drumroll.reporting.document.Document`
(:func:`table_document`): the table, its caption and notes, a run whose model does not
describe its onsets said above it, and Figure 5 when it is drawn; each number of the page
names its place in the JSON format (``/rows/0/alpha/value``).
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from drumroll.inference.results import NumberingAverage
from drumroll.reporting.document import (
    Block,
    Callout,
    Content,
    Document,
    Figure,
    Strong,
    Table,
    TableNote,
    number,
    pointer,
)
from drumroll.reporting.html import render_html
from drumroll.reporting.markdown import render_markdown
from drumroll.reporting.numbers import (
    format_value_error,
    numbering_average_text,
    value_error_number,
)
from drumroll.table.execute import Estimate, TableResult
from drumroll.table.runs import vary_spec, vary_value

#: Table columns after the label and the varied quantity: key → (plain header, LaTeX header).
COLUMNS: dict[str, tuple[str, str]] = {
    "computed_t_b": ("computed t_B (s)", r"computed $t_B$ (\si{s})"),
    "computed_t_b_pendulum": ("computed t_B, exact pendulum (s)",
                              r"computed $t_B$, exact (\si{s})"),
    "fitted_t_b": ("fitted t_B (s)", r"fitted $t_B$ (\si{s})"),
    "alpha": ("α", r"$\alpha$"),
    "alpha_averaged": ("α, models averaged", r"$\alpha$, averaged"),
}
_SHARED_MARK = "*"


def plain_symbol(key: str) -> str:
    """A parameter's symbol without mathtext, e.g. ``d`` or ``l₁``."""
    return vary_spec(key).plain


def vary_header(key: str, latex: bool = False) -> str:
    """Header of the first column: ``d (mm)`` (or ``$d$ (\\si{mm})``)."""
    spec = vary_spec(key)
    symbol = spec.symbol if latex else plain_symbol(key)
    if not spec.unit:
        return symbol
    return f"{symbol} (\\si{{{spec.unit}}})" if latex else f"{symbol} ({spec.unit})"


def table_rows(result: TableResult) -> list[dict[str, Any]]:
    """One plain dict per run: the JSON contract's rows (values unrounded).

    With a joint fit, ``fitted_t_b`` and ``alpha`` come from the joint posterior, ``shared``
    lists the parameters fitted jointly and ``alpha_separate`` keeps the run's own fit.
    """
    out = []
    joint_rows = (result.joint or {}).get("rows", {})
    for run, row in zip(result.runs.runs, result.rows, strict=True):
        vary = vary_value(run, result.runs.vary) if result.runs.vary else None
        computed, summary = row.computed_t_b, row.summary
        entry: dict[str, Any] = {
            "label": run.label,
            "group": run.group,
            "source": str(run.source),
            "vary": None if vary is None else {"key": result.runs.vary, "value": vary[0],
                                                "err": vary[1]},
            "computed_t_b": computed.get("small-angle", Estimate()).to_json(),
            "computed_t_b_pendulum": computed.get("pendulum", Estimate()).to_json(),
            "fitted_t_b": row.fitted_t_b.to_json(),
            "alpha": row.alpha.to_json(),
            "alpha_averaged": row.alpha_averaged.to_json(),
            "model": summary.model,
            "preferred": summary.preferred,
            "verdict": summary.verdict,
            "n_onsets": summary.n_onsets,
            "notes": list(summary.notes),
            "warnings": summary.warnings,
            # The main model over the first onset's numberings, where none is clearly
            # preferred (summary.json's numbering_average; else None).
            "numbering_average": (None if summary.numbering_average is None
                                  else summary.numbering_average.to_json()),
            "shared": list(result.runs.share),
        }
        if run.label in joint_rows:
            entry["alpha_separate"] = row.alpha.to_json()
            entry["fitted_t_b_separate"] = row.fitted_t_b.to_json()
            entry.update(joint_rows[run.label])
        out.append(entry)
    return out


def _cell(entry: dict[str, Any] | None, significant: int | None = None) -> str:
    if not entry or entry.get("value") is None:
        return "–"
    value, err = entry["value"], entry.get("err")
    if err is None or not (isinstance(err, float | int) and err > 0 and math.isfinite(err)):
        return f"{value:g}"
    return format_value_error(value, err, significant)


def _split(entry: dict[str, Any] | None, significant: int | None = None) -> tuple[str, str]:
    """(value, err) strings rounded as :func:`_cell` prints them (CSV)."""
    text = _cell(entry, significant)
    if text == "–":
        return "", ""
    value, _, err = text.partition(" ± ")
    return value, err


def _preferred(row: dict[str, Any]) -> str:
    return row["preferred"] or "undecided"


def _shared(row: dict[str, Any], key: str) -> str:
    return _SHARED_MARK if key in row["shared"] else ""


def _number(entry: dict[str, Any] | None, source: str, significant: int | None = None
            ) -> Content:
    """:func:`_cell`'s text as a number naming its place (``source``: the entry's pointer)."""
    text = _cell(entry, significant)
    if text == "–":
        return (text,)
    if " ± " not in text:
        return (number(entry["value"], text, f"{source}/value"),)
    return (value_error_number(entry["value"], entry["err"], f"{source}/value",
                               f"{source}/err", significant),)


#: The figure of a table: its caption and what to look for.
FIGURE_CAPTION = "Figure 5: bounce duration series"
FIGURE_NOTE = ("Each run's flight times on a log axis, with its main model's posterior "
               "median and 90 % band; runs of one group share a panel. A power law is a "
               "straight line here.")


def table_document(result: TableResult, figure: Figure | None = None) -> Document:
    """The table as a :class:`~drumroll.reporting.document.Document`: a run whose main
    model does not describe its onsets (said first), the table with its caption and notes,
    and ``figure`` (Figure 5) when given."""
    rows = table_rows(result)
    vary = result.runs.vary
    header = ["run", *([vary_header(vary)] if vary else []),
              *(plain for plain, _ in COLUMNS.values()), "preferred"]
    cells = []
    for i, row in enumerate(rows):
        here = pointer("rows", i)
        line: list[Content] = [(row["label"],)]
        if vary:
            line.append(_number(row["vary"], f"{here}/vary", 1))
        for key in COLUMNS:
            line.append((*_number(row[key], f"{here}{pointer(key)}"), _shared(row, key)))
        line.append((_preferred(row),))
        cells.append(tuple(line))
    misfits = {run.label: r.summary.misfit for run, r in zip(result.runs.runs, result.rows,
                                                             strict=True)}
    blocks: list[Block] = [
        Callout((Strong((f"⚠ {label}: the model does not fit.",)), f" {misfit}."), "warning")
        for label, misfit in misfits.items() if misfit]
    blocks.append(Table(tuple((h,) for h in header), tuple(cells),
                        caption=(result.runs.title,) if result.runs.title else (),
                        notes=notes(result, rows, said=set(misfits.values()) - {None})))
    if figure is not None:
        blocks.append(figure)
    title = result.runs.title or f"drumroll table: {result.runs.path.name}"
    return Document(title, tuple(blocks))


def to_markdown(result: TableResult) -> str:
    """A GitHub Markdown table, with the caption and notes below it."""
    return render_markdown(table_document(result))


def to_html(result: TableResult) -> str:
    """The table as one HTML page, Figure 5 embedded."""
    from drumroll.table.plot import table_png

    figure = Figure(FIGURE_CAPTION, FIGURE_NOTE, png=table_png(result)) if result.rows \
        else None
    return render_html(table_document(result, figure))


def notes(result: TableResult, rows: list[dict[str, Any]], said: set[str] = frozenset()
          ) -> tuple[TableNote, ...]:
    """The notes under the table: what the columns are, the joint fit, each run's notes on
    its onsets (other rolls, missing bounces) and warnings (but those in ``said``, already
    said above the table)."""
    out = [TableNote((
        "Computed t_B: the priors (measured geometry with its ±) propagated through the "
        "small-angle model (as in the paper) and the exact pendulum; fitted t_B and α: "
        f"posterior mean ± sd of the {rows[0]['model'] if rows else 'main'} model; α, "
        "models averaged: the fitted models' posteriors weighted by stacking on PSIS-LOO "
        "(the models' α can differ by more than their error bars).",))]
    joint = result.joint
    if joint:
        shared = ", ".join(result.runs.share)
        out.append(TableNote((
            f"{_SHARED_MARK} {shared} fitted jointly across the runs (one posterior, which "
            "also gives the rows' fitted t_B); "
            + "; ".join(f"{k} = {_cell(v)} (R-hat {v['r_hat']:.4f}, ESS "
                        f"{v['ess_bulk']:.0f})" for k, v in joint["shared"].items())
            + f"; {joint['n_steps']} steps" + ("." if joint["converged"] else
            ", stopped at the step limit before converging: raise [sampler] max_steps."),)))
        for key, entry in joint.get("separate", {}).items():
            parts = ", ".join(f"{label} {_cell(v)}" for label, v in entry.items())
            out.append(TableNote((f"Separate fits of {key}: {parts}; "
                                  f"{joint['consistency'][key]}.",)))
    for row in rows:
        out += [TableNote((f"Note ({row['label']}): {note}.",)) for note in row["notes"]]
        main = [w for w in row["warnings"] if w.startswith(f"{row['model']}:")
                or w.startswith(f"{row['model']} ")]
        for warning in main:
            if warning not in said:
                out.append(TableNote((f"Warning ({row['label']}): {warning}",), warning=True))
        averaged = row.get("numbering_average")
        if averaged:
            text = numbering_average_text(NumberingAverage.from_json(averaged))
            out.append(TableNote((f"Over the first onset's numberings ({row['label']}, "
                                  f"{row['model']}): {text}.",)))
        if len(row["warnings"]) > len(main):
            out.append(TableNote((
                f"({row['label']}: {len(row['warnings']) - len(main)} more warning(s) about "
                "the compared models; see --format json.)",)))
    return tuple(out)


def to_csv(result: TableResult) -> str:
    """CSV: each value and its uncertainty in separate columns, rounded as displayed."""
    rows = table_rows(result)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    vary = result.runs.vary
    header = ["label", "group"]
    if vary:
        header += [vary, f"{vary}_err"]
    for key in COLUMNS:
        header += [key, f"{key}_err"]
    writer.writerow([*header, "preferred", "shared"])
    for row in rows:
        cells = [row["label"], row["group"] or ""]
        if vary:
            cells += list(_split(row["vary"], 1))
        for key in COLUMNS:
            cells += list(_split(row[key]))
        writer.writerow([*cells, _preferred(row), " ".join(row["shared"])])
    return buffer.getvalue()


def _latex_escape(text: str) -> str:
    for old, new in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("_", r"\_"),
                     ("#", r"\#"), ("$", r"\$"), ("{", r"\{"), ("}", r"\}")):
        text = text.replace(old, new)
    return text


def _latex_cell(entry: dict[str, Any] | None, significant: int | None = None) -> str:
    text = _cell(entry, significant)
    if text == "–":
        return "--"
    return r"\num{" + text.replace("±", r"\pm") + "}"


def to_latex(result: TableResult) -> str:
    """A booktabs ``tabular`` with siunitx ``\\num{0.22 \\pm 0.01}`` cells."""
    rows = table_rows(result)
    vary = result.runs.vary
    header = ["run", *([vary_header(vary, latex=True)] if vary else []),
              *(tex for _, tex in COLUMNS.values()), "preferred"]
    lines = [r"% needs \usepackage{booktabs,siunitx}", r"\begin{tabular}{l" + "c" *
             (len(header) - 1) + "}", r"\toprule", " & ".join(header) + r" \\", r"\midrule"]
    for row in rows:
        cells = [_latex_escape(row["label"]), *([_latex_cell(row["vary"], 1)] if vary else [])]
        for key in COLUMNS:
            mark = f"$^{{{_SHARED_MARK}}}$" if _shared(row, key) else ""
            cells.append(_latex_cell(row[key]) + mark)
        cells.append(_latex_escape(_preferred(row)))
        lines.append(" & ".join(cells) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}"]
    return "\n".join(lines) + "\n"


def to_json(result: TableResult) -> str:
    """``{"rows": [{"label", "vary": {"value", "err"}, "computed_t_b": …}, …]}``."""
    document: dict[str, Any] = {"title": result.runs.title, "vary": result.runs.vary,
                                "share": list(result.runs.share), "rows": table_rows(result)}
    if result.joint:
        document["joint"] = {k: v for k, v in result.joint.items() if k != "rows"}
    return json.dumps(document, indent=2) + "\n"


@dataclass(frozen=True)
class TableFormat:
    """One output format of the table: its name, the file suffixes that choose it, and its
    writer (the table as the file's text)."""

    name: str
    suffixes: tuple[str, ...]
    write: Callable[[TableResult], str]


#: The table's formats, the default first.
FORMATS: dict[str, TableFormat] = {f.name: f for f in (
    TableFormat("markdown", (".md", ".markdown"), to_markdown),
    TableFormat("html", (".html", ".htm"), to_html),
    TableFormat("csv", (".csv",), to_csv),
    TableFormat("latex", (".tex",), to_latex),
    TableFormat("json", (".json",), to_json),
)}


def format_named_by(suffix: str) -> str | None:
    """The name of the format whose files end in ``suffix`` (None for other suffixes)."""
    return next((name for name, f in FORMATS.items() if suffix.lower() in f.suffixes), None)


def format_for(suffix: str) -> str:
    """The name of the format a file suffix chooses (the default, Markdown, for others)."""
    return format_named_by(suffix) or next(iter(FORMATS))


def format_table(result: TableResult, fmt: str) -> str:
    """The table in the format named ``fmt`` (one of :data:`FORMATS`)."""
    return FORMATS[fmt].write(result)
