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
from drumroll.physics.models import MODELS
from drumroll.quantities import DERIVED, QUANTITIES, report_order
from drumroll.reporting.numbers import error_decimals, format_value_error
from drumroll.reporting.plot_style import model_name, single_flights

#: Figure key → (caption, what to look for), in the order they appear in the report.
FIGURE_CAPTIONS: dict[str, tuple[str, str]] = {
    "onsets": ("Detected onsets",
               "The recording with every detected impact; check that none is missing or "
               "spurious."),
    "bounce_series": ("Bounce series",
                      "Flight time against bounce number with each model's posterior median "
                      "and 90 % band; the lower panel shows the differences from the main "
                      "model, where exact and small-angle pendulum part."),
    "residuals": ("Onset residuals",
                  "Observed minus predicted onset times with the 90 % posterior predictive "
                  "band. Random scatter: the model is adequate. A smooth pattern: the model, "
                  "not the microphone, is the limit."),
    "comparison": ("Model comparison",
                   "PSIS-LOO expected log predictive density per model (higher is better) and "
                   "the log Bayes factors against the main model."),
    "corner": ("Posterior",
               "One- and two-dimensional marginals of the main model's parameters; tilted "
               "ellipses are correlations (the pivot-height-release-speed ridge)."),
    "trace": ("Sampler trace",
              "Walkers after burn-in; they should look like stationary noise around a common "
              "level."),
}


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


def format_estimate(stats: dict[str, Any]) -> tuple[str, str]:
    """``("0.880 ± 0.002", "0.877 … 0.883")``: mean ± sd and the interval, same decimals."""
    mean, sd = stats.get("mean"), stats.get("sd")
    low, high = stats.get("hdi_low"), stats.get("hdi_high")
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


def _rhat_text(value: Any) -> str:
    if not _finite(value):
        return "—"
    value = float(value)
    return f"**{value:.4f}** ⚠" if value >= 1.01 else f"{value:.4f}"


def _ess_text(bulk: Any, tail: Any) -> str:
    def one(v: Any) -> str:
        return f"{float(v):.0f}" if _finite(v) else "—"
    text = f"{one(bulk)} / {one(tail)}"
    low = [v for v in (bulk, tail) if _finite(v) and float(v) < 400]
    return f"{text} ⚠" if low else text


def parameter_table(parameters: dict[str, dict[str, Any]], model: str = "") -> list[str]:
    """Markdown lines of the parameter table (sampled first, then derived quantities)."""
    if not parameters:
        return ["No parameter summary was produced."]
    probs = [float(s["hdi_prob"]) for s in parameters.values() if _finite(s.get("hdi_prob"))]
    prob = f"{100 * probs[0]:.0f} %" if probs else "90 %"
    lines = [f"| parameter | meaning | mean ± sd | {prob} HDI | R-hat | ESS bulk / tail |",
             "|---|---|---|---|---:|---:|"]
    for key in report_order(list(parameters)):
        stats = parameters[key]
        estimate, interval = format_estimate(stats)
        meaning = describe(key)
        sampled = MODELS[model].parameters if model in MODELS else ()
        if key in DERIVED and DERIVED[key].name not in sampled:
            meaning += " (derived)"
        lines.append(f"| {_cell(parameter_heading(key))} | {_cell(meaning)} | {estimate} | "
                     f"{interval} | {_rhat_text(stats.get('r_hat'))} | "
                     f"{_ess_text(stats.get('ess_bulk'), stats.get('ess_tail'))} |")
    lines += ["", "R-hat above 1.01 or fewer than 400 effective samples are marked ⚠: "
              "run the sampler longer before trusting the last digit."]
    return lines


def _signed(value: Any, err: Any) -> str:
    if not _finite(value):
        return "—"
    if _finite(err) and float(err) > 0:
        return format_value_error(float(value), float(err)).replace("-", "−")
    return f"{float(value):.1f}".replace("-", "−")


def comparison_section(summary: dict[str, Any]) -> list[str]:
    """Markdown lines of the model comparison: table, preferred model and verdict."""
    rows = summary.get("comparison") or []
    main = str(summary.get("model", ""))
    lines = ["## Model comparison", ""]
    if rows:
        has_bf = any(_finite(r.get("log_bayes_factor")) for r in rows)
        header = "| compared with | Δelpd_loo (main − model) |"
        rule = "|---|---:|"
        if has_bf:
            header += " ln B (ln Z_main − ln Z_model) |"
            rule += "---:|"
        lines += [header, rule]
        for row in rows:
            model = str(row.get("model", "?"))
            name = f"{model_name(model)} (`{model}`)"
            if model == main:
                name = f"**{name}**, main"
                diff = bf = "0 (reference)"
            else:
                diff = _signed(row.get("elpd_loo_diff"), row.get("elpd_loo_diff_se"))
                bf = _signed(row.get("log_bayes_factor"), row.get("log_bayes_factor_err"))
            line = f"| {_cell(name)} | {diff} |"
            if has_bf:
                line += f" {bf} |"
            lines.append(line)
        lines += ["", "Positive numbers favour the main model: it predicts the onsets better "
                  "(elpd) or is more probable given the data (ln B). A preference is claimed "
                  "only when Δelpd exceeds both 4 and twice its standard error, or |ln B| "
                  "exceeds both 1 and twice its error, without the other measure disagreeing.",
                  ""]
    else:
        lines += ["Only one model was fitted: nothing to compare.", ""]
    preferred = summary.get("preferred")
    if preferred:
        lines.append(f"**Preferred model:** {model_name(str(preferred))} (`{preferred}`).")
    elif rows:
        lines.append("**Preferred model:** none; the data do not decide between the models.")
    verdict = summary.get("verdict")
    if verdict:
        lines += ["", str(verdict)]
    lines.append("")
    return lines


def diagnostics_section(diagnostics: dict[str, dict[str, Any]]) -> list[str]:
    """Markdown lines of the sampler diagnostics, in plain words."""
    lines = ["## Sampler diagnostics", ""]
    if not diagnostics:
        return [*lines, "No sampler diagnostics were recorded.", ""]
    for model, diag in diagnostics.items():
        facts = []
        if _finite(diag.get("n_steps")):
            facts.append(f"{int(float(diag['n_steps']))} steps")
        if _finite(diag.get("tau_max")):
            facts.append(f"longest autocorrelation time {float(diag['tau_max']):.0f} steps")
        if _finite(diag.get("acceptance")):
            facts.append(f"acceptance {float(diag['acceptance']):.2f}")
        state = ("converged" if diag.get("converged")
                 else "**not converged**: the estimates may still move")
        if diag.get("converged") is None:
            state = "convergence not assessed"
        detail = f" ({', '.join(facts)})" if facts else ""
        lines.append(f"- **{model_name(model)}** (`{model}`): {state}{detail}.")
        for warning in diag.get("warnings") or []:
            lines.append(f"  - ⚠ {str(warning).strip()}")
    lines.append("")
    return lines


def figures_section(figures: dict[str, Path | str], report_dir: Path) -> list[str]:
    """Markdown lines embedding the figures with links relative to the report."""
    if not figures:
        return []
    lines = ["## Figures", ""]
    keys = [k for k in FIGURE_CAPTIONS if k in figures]
    keys += [k for k in figures if k not in FIGURE_CAPTIONS]
    for key in keys:
        caption, note = FIGURE_CAPTIONS.get(key, (key.replace("_", " ").capitalize(), ""))
        link = Path(os.path.relpath(Path(figures[key]).resolve(), report_dir.resolve()))
        lines += [f"### {caption}", "", f"![{caption}]({link.as_posix()})", ""]
        if note:
            lines += [f"*{note}*", ""]
    return lines


def _onset_rows(onsets: list[Any]) -> list[tuple[int, float, float | None]]:
    """(bounce number, time, sigma) per onset; without bounce numbers, 0, 1, 2, …"""
    rows = []
    for item in onsets:
        if isinstance(item, dict):
            t = next((item[k] for k in ("time_s", "time", "t") if k in item), None)
            s = next((item[k] for k in ("sigma_s", "sigma") if k in item), None)
            k = item.get("bounce")
        else:
            t, s, k = item, None, None
        if _finite(t):
            k = int(k) if _finite(k) else (rows[-1][0] + 1 if rows else 0)
            rows.append((k, float(t), float(s) if _finite(s) else None))
    return rows


def onsets_section(onsets: list[Any] | None) -> list[str]:
    """A folded table of the onsets: bounce number, time and flight time (only between
    consecutive bounces: across a missing bounce the interval is no single flight)."""
    rows = _onset_rows(onsets or [])
    if not rows:
        return []
    has_sigma = any(s is not None and s > 0 for _, _, s in rows)
    lines = ["<details><summary>Onset times "
             f"({len(rows)} onsets)</summary>", "",
             "| k | onset time (s) | flight time T_k (ms) |" + (" σ (ms) |" if has_sigma else ""),
             "|---:|---:|---:|" + ("---:|" if has_sigma else "")]
    ends = set(single_flights([k for k, _, _ in rows]).tolist())
    for i, (k, t, s) in enumerate(rows):
        interval = "—" if i == 0 else "— (after a gap)"
        if i in ends:
            interval = f"{(t - rows[i - 1][1]) * 1e3:.3f}"
        line = f"| {k} | {t:.6f} | {interval} |"
        if has_sigma:
            line += f" {s * 1e3:.3f} |" if s is not None else " — |"
        lines.append(line)
    return [*lines, "", "</details>", ""]


def notes_section(notes: list[str] | None) -> list[str]:
    """The notes on the onsets (other rolls, renumbering, missing bounces), one line each."""
    return [line for note in notes or [] for line in (f"> **Note:** {_cell(note)}.", "")]


def config_section(config: dict[str, Any] | None) -> list[str]:
    """The configuration used, folded away, as JSON."""
    if not config:
        return []
    text = json.dumps(config, indent=2, sort_keys=True, default=str, ensure_ascii=False)
    return ["<details><summary>Configuration used</summary>", "", "```json", text, "```", "",
            "</details>", ""]


def _headline(summary: dict[str, Any]) -> str:
    """``**Result:** α = 0.880 ± 0.002, t_B = 0.253 ± 0.001 s; preferred model: …``."""
    parameters = summary.get("parameters") or {}
    parts = []
    for key in ("alpha", "t_b"):
        stats = parameters.get(key)
        if stats and _finite(stats.get("mean")):
            estimate, _ = format_estimate(stats)
            unit = unit_of(key)
            parts.append(f"{QUANTITIES[key].plain} = {estimate}{' ' + unit if unit else ''}")
    preferred = summary.get("preferred")
    text = ", ".join(parts)
    if preferred:
        text += ("; " if text else "") + f"preferred model: {model_name(str(preferred))}"
    return f"**Result:** {text}." if text else ""


def render_report(summary: dict[str, Any], figures: dict[str, Path | str] | None = None,
                  report_dir: str | os.PathLike[str] = ".") -> str:
    """The Markdown text of the report (see :func:`write_report`)."""
    model = str(summary.get("model", "?"))
    source = summary.get("source") or "the recording"
    lines = [f"# Drumroll estimate: {_cell(Path(str(source)).name)}", ""]
    facts = [f"Model: **{model_name(model)}** (`{model}`)"]
    if _finite(summary.get("n_onsets")):
        of_roll = (f" (roll {summary['roll']} of {summary['n_rolls']})"
                   if (summary.get("n_rolls") or 1) > 1 else "")
        facts.append(f"{int(float(summary['n_onsets']))} onsets{of_roll}")
    if summary.get("version"):
        facts.append(f"drumroll {summary['version']}")
    lines += [", ".join(facts) + ".", ""]
    lines += notes_section(summary.get("notes"))
    headline = _headline(summary)
    if headline:
        lines += [headline, ""]
    lines += [f"## Parameters ({model_name(model)})", ""]
    lines += parameter_table(summary.get("parameters") or {}, model)
    lines.append("")
    lines += comparison_section(summary)
    lines += diagnostics_section(summary.get("diagnostics") or {})
    lines += figures_section(figures or {}, Path(report_dir))
    details = onsets_section(summary.get("onsets")) + config_section(summary.get("config"))
    if details:
        lines += ["## Details", "", *details]
    return "\n".join(lines).rstrip() + "\n"


def write_report(path: str | os.PathLike[str], summary: dict[str, Any],
                 figures: dict[str, Path | str] | None = None, overwrite: bool = False) -> Path:
    """Write ``report.md`` for an estimate, atomically.

    Parameters
    ----------
    path
        Destination, e.g. ``out/report.md``; figures are linked relative to its folder.
    summary
        The estimate's summary (model, n_onsets, roll, n_rolls, notes, parameters,
        comparison, preferred, verdict, diagnostics, onsets, config, version, source; see the
        module docstring).
    figures
        Figure key (``"bounce_series"``, ``"corner"``, …, ``"onsets"``) → PNG path.
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
