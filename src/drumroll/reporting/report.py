"""``report.md``: the result of ``drumroll estimate`` as a physicist would write it up.

Sections: notes on the onsets (other rolls in the recording, bounces that were not heard),
the parameters of the chosen model (mean ± sd rounded to the error, the highest-
density interval with the same decimals, R-hat and effective sample sizes), the model
comparison with its verdict, the sampler diagnostics in plain words, the figures (relative
links, so the folder can be moved or zipped as a whole), and, folded away, the onset times
and the configuration used.

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
from drumroll.reporting.figures import FIGURES
from drumroll.reporting.numbers import error_decimals, format_value_error, model_average_text
from drumroll.reporting.plot_style import model_name


def _finite(value: Any) -> bool:
    try:
        return value is not None and math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


def _cell(text: Any) -> str:
    """Text safe inside a Markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")


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


def _rhat_text(value: float | None, limit: float) -> str:
    if not _finite(value):
        return "—"
    value = float(value)
    return f"**{value:.4f}** ⚠" if value >= limit else f"{value:.4f}"


def _ess_text(bulk: float | None, tail: float | None, target: float) -> str:
    def one(v: float | None) -> str:
        return f"{float(v):.0f}" if _finite(v) else "—"
    text = f"{one(bulk)} / {one(tail)}"
    low = [v for v in (bulk, tail) if _finite(v) and float(v) < target]
    return f"{text} ⚠" if low else text


def parameter_table(parameters: dict[str, ParameterSummary], model: str = "",
                    targets: Diagnostics | None = None) -> list[str]:
    """Markdown lines of the parameter table (sampled first, then derived quantities); R-hat
    and ESS are flagged against the sampler's targets (``targets``: the model's diagnostics)."""
    if not parameters:
        return ["No parameter summary was produced."]
    targets = targets or Diagnostics()
    first = next(iter(parameters.values()))
    lines = [f"| parameter | meaning | mean ± sd | {100 * first.hdi_prob:.0f} % HDI | R-hat | "
             "ESS bulk / tail |", "|---|---|---|---|---:|---:|"]
    sampled = MODELS[model].parameters if model in MODELS else ()
    for key in report_order(list(parameters)):
        stats = parameters[key]
        estimate, interval = format_estimate(stats)
        meaning = describe(key)
        if (key in DERIVED and DERIVED[key].name not in sampled) or key in DRAW_DERIVED:
            meaning += " (derived)"
        lines.append(f"| {_cell(parameter_heading(key))} | {_cell(meaning)} | {estimate} | "
                     f"{interval} | {_rhat_text(stats.r_hat, targets.max_r_hat)} | "
                     f"{_ess_text(stats.ess_bulk, stats.ess_tail, targets.target_ess)} |")
    lines += ["", f"R-hat of {targets.max_r_hat} or more, or fewer than "
              f"{targets.target_ess:.0f} effective samples (the sampler's targets), are marked "
              "⚠: run the sampler longer before trusting the last digit."]
    return lines


def _signed(value: Any, err: Any) -> str:
    if not _finite(value):
        return "—"
    if _finite(err) and float(err) > 0:
        return format_value_error(float(value), float(err)).replace("-", "−")
    return f"{float(value):.1f}".replace("-", "−")


def comparison_section(summary: Summary) -> list[str]:
    """Markdown lines of the model comparison: table, preferred model and verdict."""
    rows = summary.comparison
    lines = ["## Model comparison", ""]
    if rows:
        has_bf = any(_finite(r.log_bayes_factor) for r in rows)
        header = "| compared with | Δelpd_loo (main − model) |"
        rule = "|---|---:|"
        has_range = any(_finite(r.log_bayes_factor_half_width) for r in rows)
        if has_bf:
            header += " ln B (ln Z_main − ln Z_model) |"
            rule += "---:|"
        if has_range:
            header += " ln B, priors only one model has half / twice as wide |"
            rule += "---:|"
        lines += [header, rule]
        reference = f"| {_cell(f'**{model_name(summary.model)} (`{summary.model}`)**, main')} | "
        lines.append(reference + "0 (reference) |" + (" 0 (reference) |" if has_bf else "")
                     + (" |" if has_range else ""))
        for row in rows:
            name = f"{model_name(row.model)} (`{row.model}`)"
            line = f"| {_cell(name)} | {_signed(row.elpd_loo_diff, row.elpd_loo_diff_se)} |"
            if has_bf:
                line += f" {_signed(row.log_bayes_factor, row.log_bayes_factor_err)} |"
            if has_range:
                if _finite(row.log_bayes_factor_half_width):
                    flag = " (prior-dominated: not weighed)" if row.prior_dominated else ""
                    line += (f" {_signed(row.log_bayes_factor_half_width, None)} / "
                             f"{_signed(row.log_bayes_factor_double_width, None)}{flag} |")
                else:
                    line += " — |"
            lines.append(line)
        lines += ["", "Positive numbers favour the main model: it predicts the onsets better "
                  "(elpd) or is more probable given the data (ln B). A preference is claimed "
                  "only when Δelpd exceeds both 4 and twice its standard error, or |ln B| "
                  "exceeds both 1 and twice its error, without the other measure disagreeing. "
                  "A Bayes factor that moves by more than 1 when the priors of the parameters "
                  "only one of the two models has are half or twice as wide (either model's, "
                  "or both) says more about those priors than about the data: it is "
                  "prior-dominated and not weighed.",
                  ""]
    else:
        lines += ["Only one model was fitted: nothing to compare.", ""]
    if summary.preferred:
        lines.append(f"**Preferred model:** {model_name(summary.preferred)} "
                     f"(`{summary.preferred}`).")
    elif rows:
        lines.append("**Preferred model:** none (the verdict below says why).")
    if summary.verdict:
        lines += ["", summary.verdict]
    averaged = model_average_text(summary.model_average)
    if averaged:
        lines += ["", f"**One α for a table**, the models averaged by how well each predicts "
                  f"the onsets left out (stacking on PSIS-LOO): {averaged}. Each model's own "
                  "α is in its section; a table of one model's α should say which."]
    lines.append("")
    return lines


def adequacy_section(summary: Summary) -> list[str]:
    """Markdown lines of each model's posterior predictive checks of its residuals."""
    checked = {m: s.adequacy for m, s in summary.models.items()
               if s.adequacy is not None and s.adequacy.checks}
    if not checked:
        return []
    level = next(iter(checked.values())).level
    lines = ["## Does each model describe the onsets?", "",
             "| model | residuals' lag-1 correlation (model's noise) | p | runs of one sign "
             "(model's noise) | p | describes the onsets |", "|---|---:|---:|---:|---:|---|"]
    for model, adequacy in checked.items():
        lag = adequacy.checks.get("lag1_autocorrelation")
        runs = adequacy.checks.get("sign_runs")
        cells = [f"{model_name(model)} (`{model}`)"]
        for check, digits in ((lag, 2), (runs, 1)):
            if check is None or check.observed is None or check.replicated is None:
                cells += ["—", "—"]
                continue
            cells += [f"{check.observed:.{digits}f} ({check.replicated:.{digits}f})",
                      "—" if check.p_value is None
                      else p_value_text(check.p_value).removeprefix("p ").removeprefix("= ")]
        cells.append("yes" if adequacy.adequate else "**no**")
        lines.append("| " + " | ".join(_cell(c) for c in cells) + " |")
    lines += ["", "Posterior predictive checks: each statistic of the standardised residuals "
              "against the same statistic of residuals replicated from the model's own noise, "
              f"draw by draw; a model fails when either p-value is below {level:g}. Neighbouring "
              "residuals that share a sign and a size (a high correlation, few runs) are a "
              "pattern the model leaves out, not timing noise.", ""]
    return lines


def diagnostics_section(diagnostics: dict[str, Diagnostics]) -> list[str]:
    """Markdown lines of the sampler diagnostics, in plain words."""
    lines = ["## Sampler diagnostics", ""]
    if not diagnostics:
        return [*lines, "No sampler diagnostics were recorded.", ""]
    for model, diag in diagnostics.items():
        facts = [f"{diag.n_steps} steps"]
        if _finite(diag.tau_max):
            facts.append(f"longest autocorrelation time {diag.tau_max:.0f} steps")
        if _finite(diag.acceptance):
            facts.append(f"acceptance {diag.acceptance:.2f}")
        state = ("converged" if diag.converged
                 else "**not converged**: the estimates may still move")
        lines.append(f"- **{model_name(model)}** (`{model}`): {state} ({', '.join(facts)}).")
        for warning in diag.warnings:
            lines.append(f"  - ⚠ {warning.strip()}")
    lines.append("")
    return lines


def figures_section(figures: dict[str, Path | str], report_dir: Path) -> list[str]:
    """Markdown lines embedding the figures (in the registry's order, with its captions),
    with links relative to the report."""
    if not figures:
        return []
    lines = ["## Figures", ""]
    for key in [k for k in FIGURES if k in figures]:
        caption, note = FIGURES[key].caption, FIGURES[key].note
        link = Path(os.path.relpath(Path(figures[key]).resolve(), report_dir.resolve()))
        lines += [f"### {caption}", "", f"![{caption}]({link.as_posix()})", "", f"*{note}*", ""]
    return lines


def onsets_section(onsets: tuple[Onset, ...]) -> list[str]:
    """A folded table of the onsets: bounce number, time and flight time (only between
    consecutive bounces: across a missing bounce the interval is no single flight)."""
    if not onsets:
        return []
    has_sigma = any(o.sigma_s > 0 for o in onsets)
    lines = ["<details><summary>Onset times "
             f"({len(onsets)} onsets)</summary>", "",
             "| k | onset time (s) | flight time T_k (ms) |" + (" σ (ms) |" if has_sigma else ""),
             "|---:|---:|---:|" + ("---:|" if has_sigma else "")]
    ends = set(single_flights([o.bounce for o in onsets]).tolist())
    for i, onset in enumerate(onsets):
        interval = "—" if i == 0 else "— (after a gap)"
        if i in ends:
            interval = f"{(onset.time_s - onsets[i - 1].time_s) * 1e3:.3f}"
        line = f"| {onset.bounce} | {onset.time_s:.6f} | {interval} |"
        if has_sigma:
            line += f" {onset.sigma_s * 1e3:.3f} |"
        lines.append(line)
    return [*lines, "", "</details>", ""]


def notes_section(notes: tuple[str, ...]) -> list[str]:
    """The notes on the onsets (other rolls, renumbering, missing bounces), one line each."""
    return [line for note in notes for line in (f"> **Note:** {_cell(note)}.", "")]


def config_section(config: dict[str, Any]) -> list[str]:
    """The configuration used, folded away, as JSON."""
    if not config:
        return []
    text = json.dumps(config, indent=2, sort_keys=True, default=str, ensure_ascii=False)
    return ["<details><summary>Configuration used</summary>", "", "```json", text, "```", "",
            "</details>", ""]


def _headline(summary: Summary) -> str:
    """``**Result:** α = 0.880 ± 0.002, t_B = 0.253 ± 0.001 s; preferred model: …``."""
    parts = []
    for key in ("alpha", "t_b"):
        stats = summary.parameters.get(key)
        if stats is not None and _finite(stats.mean):
            estimate, _ = format_estimate(stats)
            unit = unit_of(key)
            parts.append(f"{QUANTITIES[key].plain} = {estimate}{' ' + unit if unit else ''}")
    text = ", ".join(parts)
    if summary.preferred:
        text += ("; " if text else "") + f"preferred model: {model_name(summary.preferred)}"
    return f"**Result:** {text}." if text else ""


def render_report(summary: Summary, figures: dict[str, Path | str] | None = None,
                  report_dir: str | os.PathLike[str] = ".") -> str:
    """The Markdown text of the report (see :func:`write_report`)."""
    model = summary.model
    source = summary.source or "the recording"
    lines = [f"# Drumroll estimate: {_cell(Path(str(source)).name)}", ""]
    facts = [f"Model: **{model_name(model)}** (`{model}`)"]
    of_roll = f" (roll {summary.roll} of {summary.n_rolls})" if summary.n_rolls > 1 else ""
    facts.append(f"{summary.n_onsets} onsets{of_roll}")
    if summary.version:
        facts.append(f"drumroll {summary.version}")
    lines += [", ".join(facts) + ".", ""]
    lines += notes_section(summary.notes)
    misfit = summary.misfit
    if misfit:  # said before any number
        lines += [f"> **⚠ The model does not fit.** {misfit}.", ""]
    headline = _headline(summary)
    if headline:
        lines += [headline, ""]
    lines += [f"## Parameters ({model_name(model)})", ""]
    lines += parameter_table(summary.parameters, model, summary.diagnostics.get(model))
    lines.append("")
    lines += comparison_section(summary)
    lines += adequacy_section(summary)
    lines += diagnostics_section(summary.diagnostics)
    lines += figures_section(figures or {}, Path(report_dir))
    details = onsets_section(summary.onsets) + config_section(summary.config)
    if details:
        lines += ["## Details", "", *details]
    return "\n".join(lines).rstrip() + "\n"


def write_report(path: str | os.PathLike[str], summary: Summary,
                 figures: dict[str, Path | str] | None = None, overwrite: bool = False) -> Path:
    """Write ``report.md`` for an estimate, atomically.

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
    text = render_report(summary, figures, path.parent)
    return fileio.write_text(path, text, overwrite=overwrite)
