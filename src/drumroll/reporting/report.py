"""The report of ``drumroll estimate`` as a physicist would write it up: one
:class:`~drumroll.reporting.document.Document`, written as ``report.md`` and ``report.html``.

Sections, in reading order: notes on the onsets (other rolls in the recording, bounces that
were not heard), a model that does not describe the onsets and every warning (all before
any number), the headline result, the parameters of the chosen model (mean ± sd rounded to
the error, the highest-density interval with the same decimals, R-hat and effective sample
sizes), the model comparison with its verdict, each model's adequacy checks, the sampler
diagnostics in plain words, the figures with their captions, and, folded away, the onset
times and the configuration used.

Every number of a table (and of the headline) is a
:class:`~drumroll.reporting.document.Number` that names its place in ``summary.json``
(a JSON pointer: ``/parameters/alpha/mean``), so the HTML page can be checked against it.

Sign conventions of the comparison (the summary's contract): ``elpd_loo_diff`` and
``log_bayes_factor`` are *main model − model*, so positive numbers mean "better than the
model"; the main model's own row has 0.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

from drumroll import fileio
from drumroll.inference.results import (
    Diagnostics,
    Onset,
    ParameterSummary,
    Summary,
    p_value_text,
)
from drumroll.onsets.table import single_flights
from drumroll.physics.models import MODELS
from drumroll.quantities import DERIVED, DRAW_DERIVED, QUANTITIES, report_order
from drumroll.reporting.document import (
    Block,
    BulletList,
    Callout,
    Code,
    CodeBlock,
    Content,
    Details,
    Document,
    Figure,
    Heading,
    Inline,
    Paragraph,
    Strong,
    Table,
    TableNote,
    content,
    number,
    pointer,
)
from drumroll.reporting.figures import FIGURES
from drumroll.reporting.html import render_html
from drumroll.reporting.markdown import render_markdown
from drumroll.reporting.numbers import (
    error_decimals,
    first_onset_as,
    format_value_error,
    model_average_content,
    numbering_average_content,
    numbering_name,
)
from drumroll.reporting.plot_style import model_name


def _finite(value: Any) -> bool:
    try:
        return value is not None and math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


def unit_of(key: str) -> str:
    """Unit of a summary quantity ('' when dimensionless or unknown)."""
    return QUANTITIES[key].unit if key in QUANTITIES else ""


def describe(key: str) -> str:
    """Plain words for a summary quantity."""
    return QUANTITIES[key].description if key in QUANTITIES else key.replace("_", " ")


def parameter_heading(key: str) -> str:
    """``d (mm)``: symbol and unit of a summary quantity."""
    return QUANTITIES[key].plain_label() if key in QUANTITIES else key


def _fixed(value: float, decimals: int) -> str:
    """``value`` with ``decimals`` decimals (negative: rounded to tens, hundreds, …)."""
    if not _finite(value):
        return "—"
    if decimals >= 0:
        return f"{value:.{decimals}f}".replace("-", "−")
    step = 10.0 ** (-decimals)
    return f"{round(value / step) * step:.0f}".replace("-", "−")


def format_estimate(stats: ParameterSummary) -> tuple[str, str]:
    """``("0.880 ± 0.002", "0.877 … 0.883")``: mean ± sd and the interval, same decimals."""
    mean, sd, low, high = stats.mean, stats.sd, stats.hdi_low, stats.hdi_high
    if not _finite(mean):
        return "—", "—"
    if _finite(sd) and float(sd) > 0:
        decimals = error_decimals(float(sd))
        estimate = format_value_error(float(mean), float(sd))
    else:
        decimals = None
        estimate = f"{float(mean):.4g}"
    if _finite(low) and _finite(high):
        if decimals is None:
            interval = f"{float(low):.4g} … {float(high):.4g}"
        else:
            interval = f"{_fixed(float(low), decimals)} … {_fixed(float(high), decimals)}"
    else:
        interval = "—"
    return estimate.replace("-", "−"), interval


def estimate_content(stats: ParameterSummary, source: str) -> tuple[Content, Content]:
    """:func:`format_estimate`'s mean ± sd and interval as report content, each number
    naming its place (``source``: the summary's pointer, e.g. ``/parameters/alpha``)."""
    estimate, interval = format_estimate(stats)
    if estimate == "—":
        mean_cell: Content = ("—",)
    else:
        shown = " ± " in estimate
        mean_cell = (number(stats.mean, estimate, f"{source}/mean",
                            error=stats.sd if shown else None,
                            error_source=f"{source}/sd" if shown else None),)
    if interval == "—":
        return mean_cell, ("—",)
    low, high = interval.split(" … ")
    return mean_cell, (number(stats.hdi_low, low, f"{source}/hdi_low"), " … ",
                       number(stats.hdi_high, high, f"{source}/hdi_high"))


def _rhat_content(value: float | None, limit: float, source: str) -> Content:
    if not _finite(value):
        return ("—",)
    shown = number(value, f"{float(value):.4f}", source)
    return (Strong((shown,)), " ⚠") if float(value) >= limit else (shown,)


def _ess_content(bulk: float | None, tail: float | None, target: float, source: str
                 ) -> Content:
    def one(v: float | None, key: str) -> Inline:
        return number(v, f"{float(v):.0f}", f"{source}/{key}") if _finite(v) else "—"

    low = [v for v in (bulk, tail) if _finite(v) and float(v) < target]
    return (one(bulk, "ess_bulk"), " / ", one(tail, "ess_tail"), " ⚠" if low else "")


def parameter_table(parameters: dict[str, ParameterSummary], model: str = "",
                    targets: Diagnostics | None = None,
                    source: str = "/parameters") -> tuple[Block, ...]:
    """The parameter table (sampled first, then derived quantities); R-hat and ESS are
    flagged against the sampler's targets (``targets``: the model's diagnostics). Its numbers
    point into ``source`` (the summaries' place in ``summary.json``)."""
    if not parameters:
        return (Paragraph(("No parameter summary was produced.",)),)
    targets = targets or Diagnostics()
    first = next(iter(parameters.values()))
    header = (("parameter",), ("meaning",), ("mean ± sd",),
              (f"{100 * first.hdi_prob:.0f} % HDI",), ("R-hat",), ("ESS bulk / tail",))
    sampled = MODELS[model].parameters if model in MODELS else ()
    rows = []
    for key in report_order(list(parameters)):
        stats = parameters[key]
        here = pointer_join(source, key)
        estimate, interval = estimate_content(stats, here)
        meaning = describe(key)
        if (key in DERIVED and DERIVED[key].name not in sampled) or key in DRAW_DERIVED:
            meaning += " (derived)"
        if stats.probability_zero is not None:  # a prior with an atom at 0
            meaning += f"; 0 (absent) with probability {stats.probability_zero:.2f}"
        rows.append(((parameter_heading(key),), (meaning,), estimate, interval,
                     _rhat_content(stats.r_hat, targets.max_r_hat, f"{here}/r_hat"),
                     _ess_content(stats.ess_bulk, stats.ess_tail, targets.target_ess, here)))
    note = (f"R-hat of {targets.max_r_hat} or more, or fewer than {targets.target_ess:.0f} "
            "effective samples (the sampler's targets), are marked ⚠: run the sampler longer "
            "before trusting the last digit.")
    return (Table(header, tuple(rows), (None, None, None, None, "right", "right"),
                  notes=(TableNote((note,)),)),)


def pointer_join(base: str, *parts: str | int) -> str:
    """``base`` (a JSON pointer) extended by ``parts``."""
    return base + pointer(*parts)


def _signed(value: Any, err: Any, source: str, error_source: str | None = None) -> Content:
    if not _finite(value):
        return ("—",)
    if _finite(err) and float(err) > 0:
        text = format_value_error(float(value), float(err)).replace("-", "−")
        shown = " ± " in text
        return (number(value, text, source, error=err if shown else None,
                       error_source=error_source if shown else None),)
    return (number(value, f"{float(value):.1f}".replace("-", "−"), source),)


def _model(model: str) -> Content:
    """``exact pendulum (`pendulum`)``."""
    return (f"{model_name(model)} (", Code(model), ")")


def comparison_section(summary: Summary) -> tuple[Block, ...]:
    """The model comparison: table, preferred model and verdict."""
    rows = summary.comparison
    blocks: list[Block] = [Heading(2, ("Model comparison",))]
    if rows:
        has_bf = any(_finite(r.log_bayes_factor) for r in rows)
        has_range = any(_finite(r.log_bayes_factor_half_width) for r in rows)
        header: list[Content] = [("compared with",), ("Δelpd_loo (main − model)",)]
        align: list[Any] = [None, "right"]
        if has_bf:
            header.append(("ln B (ln Z_main − ln Z_model)",))
            align.append("right")
        if has_range:
            header.append(("ln B, priors only one model has half / twice as wide",))
            align.append("right")
        reference: list[Content] = [(Strong(_model(summary.model)), ", main"),
                                    ("0 (reference)",)]
        if has_bf:
            reference.append(("0 (reference)",))
        if has_range:
            reference.append(())
        cells = [tuple(reference)]
        for i, row in enumerate(rows):
            here = pointer("comparison", i)
            line: list[Content] = [_model(row.model), _signed(
                row.elpd_loo_diff, row.elpd_loo_diff_se, f"{here}/elpd_loo_diff",
                f"{here}/elpd_loo_diff_se")]
            if has_bf:
                line.append(_signed(row.log_bayes_factor, row.log_bayes_factor_err,
                                    f"{here}/log_bayes_factor", f"{here}/log_bayes_factor_err"))
            if has_range:
                if _finite(row.log_bayes_factor_half_width):
                    flag = " (prior-dominated: not weighed)" if row.prior_dominated else ""
                    line.append(content(
                        _signed(row.log_bayes_factor_half_width, None,
                                f"{here}/log_bayes_factor_half_width"), " / ",
                        _signed(row.log_bayes_factor_double_width, None,
                                f"{here}/log_bayes_factor_double_width"), flag))
                else:
                    line.append(("—",))
            cells.append(tuple(line))
        note = ("Positive numbers favour the main model: it predicts the onsets better "
                "(elpd) or is more probable given the data (ln B). A preference is claimed "
                "only when Δelpd exceeds both 4 and twice its standard error, or |ln B| "
                "exceeds both 1 and twice its error, without the other measure disagreeing. "
                "A Bayes factor that moves by more than 1 when the priors of the parameters "
                "only one of the two models has are half or twice as wide (either model's, "
                "or both) says more about those priors than about the data: it is "
                "prior-dominated and not weighed.")
        blocks.append(Table(tuple(header), tuple(cells), tuple(align),
                            notes=(TableNote((note,)),)))
    else:
        blocks.append(Paragraph(("Only one model was fitted: nothing to compare.",)))
    if summary.preferred:
        blocks.append(Paragraph((Strong(("Preferred model:",)), " ",
                                 *_model(summary.preferred), ".")))
    elif rows:
        blocks.append(Paragraph((Strong(("Preferred model:",)),
                                 " none (the verdict below says why).")))
    if summary.verdict:
        blocks.append(Paragraph((summary.verdict,)))
    averaged = model_average_content(summary.model_average)
    if averaged:
        blocks.append(Paragraph(content(
            Strong(("One α for a table",)), ", the models averaged by how well each predicts "
            "the onsets left out (stacking on PSIS-LOO): ", averaged, ". Each model's own α is "
            "in its section; a table of one model's α should say which.")))
    return tuple(blocks)


def numbering_average_section(summary: Summary) -> tuple[Block, ...]:
    """The main model's every quantity averaged over the first onset's numberings, where
    no numbering is clearly preferred."""
    average = summary.numbering_average
    if average is None or not average.parameters:
        return ()
    weights = ", ".join(f"{numbering_name(m)}: {w:.2f}"
                        for m, w in average.probabilities.items())
    return (Heading(3, ("Averaged over the first onset's numberings",)),
            Paragraph((f"The table above takes the first onset as "
                       f"{first_onset_as(average.fitted)}. No numbering is clearly preferred, so "
                       "this one mixes the posteriors of the numberings by their "
                       f"probabilities (impacts missed before the first onset, or the first "
                       f"onset no impact of the roll: {weights}). R-hat and ESS belong to each "
                       "numbering's own run, not to their mixture.",)),
            *parameter_table(average.parameters, summary.model,
                             source="/numbering_average/parameters"))


def adequacy_section(summary: Summary) -> tuple[Block, ...]:
    """Each model's posterior predictive checks of its residuals."""
    checked = {m: s.adequacy for m, s in summary.models.items()
               if s.adequacy is not None and s.adequacy.checks}
    if not checked:
        return ()
    level = next(iter(checked.values())).level
    header = (("model",), ("residuals' lag-1 correlation (model's noise)",), ("p",),
              ("runs of one sign (model's noise)",), ("p",),
              ("drift as a scattering restitution makes it (model's noise)",), ("p",),
              ("describes the onsets",))
    rows = []
    for model, adequacy in checked.items():
        cells: list[Content] = [_model(model)]
        for name, digits in (("lag1_autocorrelation", 2), ("sign_runs", 1),
                             ("scatter_walk", 1)):
            check = adequacy.checks.get(name)
            if check is None or check.observed is None or check.replicated is None:
                cells += [("—",), ("—",)]
                continue
            here = pointer("models", model, "adequacy", "checks", name)
            cells.append((number(check.observed, f"{check.observed:.{digits}f}",
                                 f"{here}/observed"), " (",
                          number(check.replicated, f"{check.replicated:.{digits}f}",
                                 f"{here}/replicated"), ")"))
            cells.append(("—",) if check.p_value is None else (number(
                check.p_value, p_value_text(check.p_value).removeprefix("p ")
                .removeprefix("= "), f"{here}/p_value"),))
        cells.append(("yes",) if adequacy.adequate else (Strong(("no",)),))
        rows.append(tuple(cells))
    note = ("Posterior predictive checks: each statistic of the standardised residuals "
            "against the same statistic of residuals replicated from the model's own noise, "
            f"draw by draw; a model fails when any p-value is below {level:g}. Neighbouring "
            "residuals that share a sign and a size (a high correlation, few runs) are a "
            "pattern the model leaves out, not timing noise. The drift is how much of the "
            "residuals, once what the model's parameters can follow is taken out, lies "
            "where a restitution that scatters from bounce to bounce moves the onsets, "
            "against what independent noise puts there (1).")
    return (Heading(2, ("Does each model describe the onsets?",)),
            Table(header, tuple(rows),
                  (None, "right", "right", "right", "right", "right", "right", None),
                  notes=(TableNote((note,)),)))


def diagnostics_section(diagnostics: dict[str, Diagnostics]) -> tuple[Block, ...]:
    """The sampler diagnostics, in plain words (their warnings are said at the top)."""
    heading = Heading(2, ("Sampler diagnostics",))
    if not diagnostics:
        return (heading, Paragraph(("No sampler diagnostics were recorded.",)))
    items = []
    for model, diag in diagnostics.items():
        here = pointer("diagnostics", model)
        facts: list[Content] = [(number(diag.n_steps, f"{diag.n_steps}", f"{here}/n_steps"),
                                 " steps")]
        if _finite(diag.tau_max):
            facts.append(("longest autocorrelation time ",
                          number(diag.tau_max, f"{diag.tau_max:.0f}", f"{here}/tau_max"),
                          " steps"))
        if _finite(diag.acceptance):
            facts.append(("acceptance ", number(diag.acceptance, f"{diag.acceptance:.2f}",
                                                f"{here}/acceptance")))
        state: Content = (("converged",) if diag.converged else
                          (Strong(("not converged",)), ": the estimates may still move"))
        listed = content(*[(", " if i else "", fact) for i, fact in enumerate(facts)])
        items.append(content(Strong((model_name(model),)), " (", Code(model), "): ", state,
                             " (", listed, ")."))
    return (heading, BulletList(tuple(items)))


def figures_section(figures: dict[str, Path | str]) -> tuple[Block, ...]:
    """The figures, in the registry's order, with its captions."""
    if not figures:
        return ()
    return (Heading(2, ("Figures",)),
            *(Figure(FIGURES[key].caption, FIGURES[key].note, path=Path(figures[key]))
              for key in FIGURES if key in figures))


def onsets_section(onsets: tuple[Onset, ...]) -> tuple[Block, ...]:
    """A folded table of the onsets: bounce number, time and flight time (only between
    consecutive bounces: across a missing bounce the interval is no single flight)."""
    if not onsets:
        return ()
    has_sigma = any(o.sigma_s > 0 for o in onsets)
    header: tuple[Content, ...] = (("k",), ("onset time (s)",), ("flight time T_k (ms)",))
    if has_sigma:
        header += (("σ (ms)",),)
    ends = set(single_flights([o.bounce for o in onsets]).tolist())
    rows = []
    for i, onset in enumerate(onsets):
        here = pointer("onsets", i)
        flight: Content = ("—",) if i == 0 else ("— (after a gap)",)
        if i in ends:
            value = (onset.time_s - onsets[i - 1].time_s) * 1e3
            flight = (number(value, f"{value:.3f}",
                             pointer("observed_flights", "time_s", onset.bounce - 1),
                             scale=1e3),)
        row: tuple[Content, ...] = (
            (number(onset.bounce, f"{onset.bounce}", f"{here}/bounce"),),
            (number(onset.time_s, f"{onset.time_s:.6f}", f"{here}/time_s"),), flight)
        if has_sigma:
            row += ((number(onset.sigma_s * 1e3, f"{onset.sigma_s * 1e3:.3f}",
                            f"{here}/sigma_s", scale=1e3),),)
        rows.append(row)
    table = Table(header, tuple(rows), ("right",) * len(header))
    return (Details(f"Onset times ({len(onsets)} onsets)", (table,)),)


def notes_section(notes: tuple[str, ...]) -> tuple[Block, ...]:
    """The notes on the onsets (other rolls, renumbering, missing bounces), one each."""
    return tuple(Callout((Strong(("Note:",)), f" {note}."), "note") for note in notes)


def warnings_section(summary: Summary) -> tuple[Block, ...]:
    """A main model that does not describe the onsets, then every other warning: what the
    reader must know before reading any number."""
    misfit = summary.misfit
    blocks: list[Block] = []
    if misfit:
        blocks.append(Callout((Strong(("⚠ The model does not fit.",)), f" {misfit}."),
                              "warning"))
    others = [w.strip() for w in summary.warnings if w != misfit]
    if others:
        blocks += [Paragraph((Strong(("Warnings",)), ", to read before the numbers:")),
                   BulletList(tuple((f"⚠ {w}",) for w in others), kind="warning")]
    return tuple(blocks)


def config_section(config: dict[str, Any]) -> tuple[Block, ...]:
    """The configuration used, folded away, as JSON."""
    if not config:
        return ()
    text = json.dumps(config, indent=2, sort_keys=True, default=str, ensure_ascii=False)
    return (Details("Configuration used", (CodeBlock(text, "json"),)),)


def headline(summary: Summary) -> tuple[Block, ...]:
    """``**Result:** α = 0.880 ± 0.002, t_B = 0.253 ± 0.001 s; preferred model: …``."""
    parts: list[Content] = []
    for key in ("alpha", "t_b"):
        stats = summary.parameters.get(key)
        if stats is not None and _finite(stats.mean):
            estimate, _ = estimate_content(stats, pointer("parameters", key))
            unit = unit_of(key)
            parts.append((f"{QUANTITIES[key].plain} = ", *estimate, f" {unit}" if unit else ""))
    text = content(*[(", " if i else "", part) for i, part in enumerate(parts)])
    if summary.preferred:
        text = content(text, "; " if text else "",
                       f"preferred model: {model_name(summary.preferred)}")
    blocks = [Paragraph((Strong(("Result:",)), " ", *text, "."))] if text else []
    over_numberings = numbering_average_content(summary.numbering_average)
    if over_numberings:
        blocks.append(Paragraph((
            Strong(("Over the first onset's numberings:",)), " ", *over_numberings,
            f". No numbering is clearly preferred: the numbers above, the tables and the "
            f"figures take the first onset as {first_onset_as(summary.numbering_average.fitted)}; "
            "these mix every numbering's posterior by its probability.")))
    return tuple(blocks)


def report_title(summary: Summary) -> str:
    """``Drumroll estimate: roll.flac``."""
    return f"Drumroll estimate: {Path(str(summary.source or 'the recording')).name}"


def _facts(summary: Summary) -> Paragraph:
    model = summary.model
    of_roll = f" (roll {summary.roll} of {summary.n_rolls})" if summary.n_rolls > 1 else ""
    facts: list[Content] = [("Model: ", Strong((model_name(model),)), " (", Code(model), ")"),
                            (f"{summary.n_onsets} onsets{of_roll}",)]
    if summary.version:
        facts.append((f"drumroll {summary.version}",))
    return Paragraph(content(*[(", " if i else "", f) for i, f in enumerate(facts)], "."))


def lead(summary: Summary) -> tuple[Block, ...]:
    """The report's opening, up to its headline: the title, the notes and warnings (before
    any number), what was fitted, the headline result."""
    return (Heading(1, (report_title(summary),)), *notes_section(summary.notes),
            *warnings_section(summary), _facts(summary), *headline(summary))


def estimate_document(summary: Summary, figures: dict[str, Path | str] | None = None
                      ) -> Document:
    """The report of an estimate as a :class:`~drumroll.reporting.document.Document`.

    Parameters
    ----------
    summary
        The estimate's summary (``summary.json``).
    figures
        Figure key (:data:`~drumroll.reporting.figures.FIGURES`) → PNG path.
    """
    model = summary.model
    blocks: list[Block] = [*lead(summary), Heading(2, (f"Parameters ({model_name(model)})",)),
                           *parameter_table(summary.parameters, model,
                                            summary.diagnostics.get(model)),
                           *numbering_average_section(summary),
                           *comparison_section(summary), *adequacy_section(summary),
                           *diagnostics_section(summary.diagnostics),
                           *figures_section(figures or {})]
    details = (*onsets_section(summary.onsets), *config_section(summary.config))
    if details:
        blocks += [Heading(2, ("Details",)), *details]
    return Document(report_title(summary), tuple(blocks))


def render_report(summary: Summary, figures: dict[str, Path | str] | None = None,
                  report_dir: str | os.PathLike[str] = ".") -> str:
    """The Markdown text of the report (see :func:`write_report`)."""
    return render_markdown(estimate_document(summary, figures), report_dir)


def write_report(path: str | os.PathLike[str], summary: Summary,
                 figures: dict[str, Path | str] | None = None, overwrite: bool = False) -> Path:
    """Write the report of an estimate, atomically: ``report.md`` (Markdown, figures linked)
    or, for a path ending in ``.html``, ``report.html`` (one page, figures embedded).

    Parameters
    ----------
    path
        Destination, e.g. ``out/report.md``; figures are linked relative to its folder.
    summary
        The estimate's summary.
    figures
        Figure key (:data:`~drumroll.reporting.figures.FIGURES`) → PNG path.
    overwrite
        Replace an existing report.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    drumroll.errors.DrumrollError
        If ``path`` exists and ``overwrite`` is false, or its folder does not exist.
    """
    path = Path(path)
    fileio.check_writable(path, overwrite=overwrite)
    document = estimate_document(summary, figures)
    text = (render_html(document) if path.suffix.lower() in (".html", ".htm")
            else render_markdown(document, path.parent))
    return fileio.write_text(path, text, overwrite=overwrite)
