"""``drumroll calibrate``'s outputs: ``report.md`` (from one function returning its sections,
which another renderer can take as they are), ``calibration.json``, and the figures, written
together into one folder.

The report: the headline (which parameters pass, which fail: a parameter passes when its
90 % coverage lies inside the binomial 99 % band and its rank histogram passes Pearson's χ²
test at 1 %, the acceptance of issue 14), the table (coverage with error bars, χ² p-value, mean
z-score, contraction), the same for the derived quantities, what the extractor changes (with
``--audio``), how the run was made, and the figures (Talts et al. 2018, arXiv:1804.06788).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drumroll import fileio
from drumroll.errors import DrumrollError
from drumroll.inference.calibration import MIN_EXPECTED
from drumroll.quantities import QUANTITIES
from drumroll.reporting.plot_style import missing_glyphs_said_once

#: The outputs, in the order they are written (the report last: it links the figures).
CALIBRATION_FILES = {"json": "calibration.json", "ranks": "ranks.png",
                     "coverage": "coverage.png", "report": "report.md"}


@dataclass(frozen=True)
class Section:
    """One section of the report: a title (None: the headline, before any title) and its
    Markdown lines."""

    title: str | None
    lines: tuple[str, ...]


def _label(key: str) -> str:
    """``α``, ``d`` (the plain symbol) and the key, for a table's first column."""
    q = QUANTITIES.get(key)
    return f"{q.plain} (`{key}`)" if q is not None else f"`{key}`"


def _unit(key: str) -> str:
    q = QUANTITIES.get(key)
    return q.unit if q is not None and q.unit else "—"


def _number(value: Any, text: str) -> str:
    try:
        value = float(value)
    except (TypeError, ValueError):
        return "—"
    return format(value, text).replace("-", "−") if math.isfinite(value) else "—"


def _coverage(c: Any) -> str:
    """``0.91 ± 0.02`` (the error: half the 68 % Clopper–Pearson interval), bold with ⚠
    outside the 99 % band."""
    text = f"{c.rate:.2f} ± {c.error:.2f}"
    return text if c.inside else f"**{text}** ⚠"


def _p_value(p: Any) -> str:
    text = _number(p, ".2g")
    try:
        low = float(p) < 0.01
    except (TypeError, ValueError):
        low = False
    return f"**{text}** ⚠" if low else text


def quantity_table(level: Any, keys: tuple[str, ...]) -> list[str]:
    """Markdown lines of the table of ``keys`` in one calibration ``level``."""
    lines = ["| quantity | unit | 50 % coverage | 90 % coverage | χ² p | mean z | sd z | "
             "contraction | |", "|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for key in keys:
        q = level.quantities[key]
        lines.append(
            f"| {_label(key)} | {_unit(key)} | {_coverage(q.coverage_50)} | "
            f"{_coverage(q.coverage_90)} | {_p_value(q.chi_square.p_value)} | "
            f"{_number(q.mean_z, '+.2f')} | {_number(q.sd_z, '.2f')} | "
            f"{_number(q.contraction, '.3f')} | {'pass' if q.passed else '**fail**'} |")
    return lines


def _failure(q: Any) -> str:
    """Why a quantity failed, in numbers."""
    c = q.coverage_90
    why = []
    if not c.inside:
        why.append(f"90 % coverage {c.rate:.2f}, outside {c.band_low:.2f} … {c.band_high:.2f}")
    if q.chi_square.p_value < 0.01:
        why.append(f"ranks not uniform, χ² p = {q.chi_square.p_value:.2g}")
    return f"{_label(q.key)} ({'; '.join(why)})"


def headline(result: Any) -> list[str]:
    """The verdict before any number: which parameters pass and which fail, per level."""
    settings = result.settings
    what = (f"{settings.n} rolls of {settings.n_onsets} onsets drawn from the priors of the "
            f"{settings.model} model and fitted as `estimate` fits them")
    lines = []
    for name, level in result.levels.items():
        source = ("the simulated onsets" if name == "onsets"
                  else "the onsets the extractor found in each roll's recording")
        failed = level.failed()
        if not failed:
            listed = ", ".join(map(_label, level.parameters))
            tested = all(level.quantities[k].chi_square.dof for k in level.parameters)
            verdict = (f"**Every parameter is calibrated** ({listed}): its 90 % coverage lies "
                       "inside the binomial 99 % band"
                       + (" and its ranks pass the χ² test at 1 %" if tested else ""))
        else:
            verdict = ("**Not calibrated:** "
                       + "; ".join(_failure(level.quantities[k]) for k in failed)
                       + (f". The other parameters pass "
                          f"({', '.join(_label(k) for k in level.parameters if k not in failed)})"
                          if len(failed) < len(level.parameters) else ""))
        derived_failed = level.failed(level.derived)
        derived = ""
        if level.derived:
            derived = " Derived quantities: " + (
                "all pass." if not derived_failed
                else f"fail: {', '.join(map(_label, derived_failed))}.")
        lines += [f"Fitting {source}: {verdict}.{derived}", ""]
    if any(q.chi_square.dof == 0 for q in result.onsets.quantities.values()):
        lines += [f"{settings.n} simulations are too few for the χ² test of the ranks (it "
                  f"needs {2 * MIN_EXPECTED} or more): the coverage alone decides.", ""]
    lines.insert(0, f"Simulation-based calibration (Talts et al. 2018) of {what}.")
    lines.insert(1, "")
    return lines


def _audio_section(result: Any) -> list[str]:
    """What hearing the rolls changes: the extractor's record, and the coverage side by side."""
    draws = [d for d in result.draws if d.hearing is not None]
    if result.audio is None or not draws:
        return []
    n = len(draws)
    heard = [d.hearing for d in draws]
    first_heard = sum(h.first == 0 for h in heard)
    stray_first = sum(h.first < 0 for h in heard)
    missed_first = sum(h.first > 0 for h in heard)
    misnumbered = sum(h.misnumbered > 0 for h in heard)
    fraction = sorted(h.n_heard / h.n_impacts for h in heard)
    median_error = sorted(h.median_error_ms for h in heard if h.median_error_ms is not None)
    middle = fraction[len(fraction) // 2]
    lines = [
        f"Each simulated roll was also rendered as a recording (the renderer of `drumroll "
        f"simulate`, with the config's `[simulate]` sound) and its onsets found by the "
        f"extractor, then fitted in the same way, with the same truths. Of the {n} "
        f"recordings the extractor numbered the roll from its first impact in {first_heard}, "
        f"took a stray sound (the tap before the roll) for its first bounce in {stray_first}, "
        f"and missed the first impact in {missed_first}; {misnumbered} had at least one "
        f"onset whose number is not its impact's. It kept a median {middle:.0%} of the "
        f"impacts, each onset a median "
        f"{median_error[len(median_error) // 2] if median_error else math.nan:.2f} ms from its "
        "impact.", "",
        "| quantity | 90 % coverage, onsets | 90 % coverage, heard | mean z, onsets | "
        "mean z, heard | sd z, onsets | sd z, heard |", "|---|---:|---:|---:|---:|---:|---:|"]
    for key in (*result.audio.parameters, *result.audio.derived):
        a, b = result.onsets.quantities[key], result.audio.quantities[key]
        lines.append(f"| {_label(key)} | {_coverage(a.coverage_90)} | "
                     f"{_coverage(b.coverage_90)} | {_number(a.mean_z, '+.2f')} | "
                     f"{_number(b.mean_z, '+.2f')} | {_number(a.sd_z, '.2f')} | "
                     f"{_number(b.sd_z, '.2f')} |")
    return [*lines, ""]


def _method_lines(result: Any) -> list[str]:
    settings = result.settings
    sampler = settings.sampler
    rejected = result.rejected
    n_rejected = sum(rejected.values())
    lines = [
        f"- Config: `{result.config_path or '(given in Python)'}`, model `{settings.model}`, "
        f"`{settings.noise}` onset noise. Each simulation draws θ from the priors (a draw the "
        "physics forbids is drawn again: the prior the fit uses is truncated to those points), "
        f"simulates {settings.n_onsets} onsets through the model's forward model with its "
        "timing noise (and restitution scatter and contact time where the config has them), "
        "every bounce heard, and fits them with `estimate`'s sampler settings "
        f"({sampler.get('walkers')} walkers until bulk and tail ESS ≥ "
        f"{sampler.get('target_ess', 0):.0f} and R-hat < {sampler.get('max_r_hat')}, at most "
        f"{sampler.get('max_steps')} steps). The compared models and the evidence are not "
        "computed (nor, with `missed_first`, the renumbered fits' evidences): they serve the model "
        "comparison and leave the main posterior unchanged.",
        f"- Ranks: the truth among {settings.rank_draws} posterior draws chosen at random among "
        "draws one autocorrelation time apart (nearly independent), histogram bins dividing the "
        "rank values evenly; coverage: central intervals of all the stored draws (at most "
        "3,000); z = (posterior mean − truth) / posterior sd; contraction = 1 − posterior "
        "variance / prior variance (T0's prior: its flat 1 s window).",
        f"- Seed {settings.seed}; simulation i's seeds derive from the seed and i alone. "
        f"{result.seconds:.0f} s of wall time, {result.cpu_seconds:.0f} s summed over the "
        f"simulations; drumroll {result.versions.get('drumroll', '?')}.",
    ]
    if n_rejected:
        reasons = "; ".join(f"{reason}: {count}" for reason, count in rejected.items())
        lines.append(
            f"- {n_rejected} of {result.attempts} parameter draws were made again ({reasons}). "
            "A roll refused for its data alone (onsets out of time order, too few heard) "
            "leaves the calibration valid, as the posterior given data that pass a check on "
            "the data is the posterior given the data; the rolls calibrated are those that "
            "pass.")
    for name, level in result.levels.items():
        if level.unconverged or level.inadequate:
            lines.append(f"- Fits of the {name}: {level.unconverged} stopped at the step limit "
                         f"before the ESS and R-hat targets; {level.inadequate} were flagged by "
                         "the residual checks (the model is the truth here: the checks' false "
                         "alarms).")
    k = len(result.onsets.parameters)
    lines.append(f"- With {k} parameters each tested at 1 %, a calibrated inference fails at "
                 f"least one test in about {1 - 0.99 ** (2 * k):.0%} of runs (less, as the "
                 "tests are correlated): one failure near the band's edge is weak evidence; a "
                 "failure by far, or a shape in the ranks, is not.")
    return lines


def calibration_sections(result: Any, figures: dict[str, str] | None = None
                         ) -> list[Section]:
    """The report of a :class:`~drumroll.calibration.CalibrationResult` as sections: the
    headline, the parameters' table, the derived quantities', the extractor's (with audio),
    how to read it, how it was made, and the figures (``figures``: key → file name relative
    to the report)."""
    onsets = result.onsets
    sections = [Section(None, tuple(headline(result)))]
    sections.append(Section("Parameters", tuple(quantity_table(onsets, onsets.parameters))))
    if onsets.derived:
        sections.append(Section("Derived quantities", tuple(
            ["Functions of the parameters, calibrated as the parameters are (any function of "
             "θ has uniform ranks when the posterior is right).", "",
             *quantity_table(onsets, onsets.derived)])))
    if result.audio is not None:
        sections.append(Section("From recordings: what the extractor changes",
                                tuple(_audio_section(result))))
    sections.append(Section("How to read it", (
        "Coverage is the share of simulations whose central interval held the truth, ± half "
        "its 68 % Clopper–Pearson interval; ⚠ marks a coverage outside the band a calibrated "
        "posterior's falls in with 99 % probability (binomial). χ² p tests that the ranks of "
        "the truth among the posterior draws are uniform (Talts et al. 2018); ⚠ below 0.01. "
        "Mean z near 0 and sd z near 1 say the posterior mean is unbiased and its sd honest; "
        "a ∪-shaped rank histogram says the posterior is too narrow, a ∩ too wide, a slope "
        "biased. Contraction near 1: the data, not the prior, set the parameter; near 0: the "
        "prior does (its coverage then says little about the data).",)))
    sections.append(Section("How it was made", tuple(_method_lines(result))))
    if figures:
        lines = []
        for key, title in (("ranks", "Rank histograms"), ("coverage", "Coverage")):
            if key in figures:
                lines += [f"![{title}]({figures[key]})", ""]
        sections.append(Section("Figures", tuple(lines)))
    return sections


def render_markdown(sections: list[Section], title: str) -> str:
    """The sections as one Markdown document under ``title``."""
    lines = [f"# {title}", ""]
    for section in sections:
        if section.title is not None:
            lines += [f"## {section.title}", ""]
        body = list(section.lines)
        while body and not body[-1]:
            body.pop()
        lines += [*body, ""]
    return "\n".join(lines).rstrip() + "\n"


def report_markdown(result: Any, figures: dict[str, str] | None = None) -> str:
    """``report.md`` of a calibration."""
    title = f"Calibration of the {result.settings.model} model"
    return render_markdown(calibration_sections(result, figures), title)


def check_calibration_outputs(out_dir: str | os.PathLike[str], *, overwrite: bool = False
                              ) -> Path:
    """Refuse, before any work, an output folder that is a file, where nothing can be
    written, or that holds a calibration's files (without ``overwrite``)."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise DrumrollError(f"{out_dir}: exists and is not a directory")
    fileio.check_folder_writable(out_dir if out_dir.is_dir() else out_dir.parent)
    if not overwrite and out_dir.is_dir():
        existing = [name for name in CALIBRATION_FILES.values() if (out_dir / name).exists()]
        if existing:
            raise DrumrollError(f"{out_dir}: would overwrite {', '.join(existing)} (use --force "
                                "or another --out)")
    return out_dir


def write_calibration(result: Any, out_dir: str | os.PathLike[str], *,
                      overwrite: bool = False) -> dict[str, Path]:
    """Write ``calibration.json``, ``ranks.png``, ``coverage.png`` and ``report.md`` into
    ``out_dir`` together: all of them or, if one fails (a full disk), none, and a folder this
    made is removed again.

    Returns
    -------
    dict
        Output key (:data:`CALIBRATION_FILES`) → path.
    """
    from drumroll.reporting.calibration_plots import plot_coverage, plot_ranks

    out_dir = check_calibration_outputs(out_dir, overwrite=overwrite)
    created = not out_dir.exists()
    try:
        out_dir.mkdir(exist_ok=True)
    except OSError as exc:
        if fileio.no_space(exc):
            raise fileio.no_space_error(out_dir, exc) from None
        raise
    paths = {key: out_dir / name for key, name in CALIBRATION_FILES.items()}
    text = json.dumps(result.to_json(), indent=1, ensure_ascii=False) + "\n"
    report = report_markdown(result, {k: CALIBRATION_FILES[k] for k in ("ranks", "coverage")})
    written = False
    try:
        with missing_glyphs_said_once(CALIBRATION_FILES["ranks"]):
            fileio.write_together({
                paths["json"]: lambda tmp: tmp.write_text(text, encoding="utf-8"),
                paths["ranks"]: lambda tmp: plot_ranks(result, tmp, overwrite=True),
                paths["coverage"]: lambda tmp: plot_coverage(result, tmp, overwrite=True),
                paths["report"]: lambda tmp: tmp.write_text(report, encoding="utf-8"),
            }, overwrite=overwrite)
        written = True
    finally:
        if created and not written:  # a folder this made, left empty: not left behind
            with contextlib.suppress(OSError):
                out_dir.rmdir()
    return paths
