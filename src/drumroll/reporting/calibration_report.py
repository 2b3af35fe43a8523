"""``drumroll calibrate``'s outputs: the report as one document
(:func:`calibration_document`, rendered as ``report.md`` and ``report.html`` by
:mod:`drumroll.reporting.document`'s renderers), ``calibration.json`` and the figures, written
together into one folder.

The report: the headline (which parameters pass, which fail: a parameter passes when its
90 % coverage lies inside the binomial 99 % band and its rank histogram passes Pearson's χ²
test at 1 %, the acceptance of issue 14), the table (coverage with error bars, χ² p-value, mean
and sd of the z-score, contraction), the same for the derived quantities, what the extractor
changes (with ``--audio``), how to read it, how the run was made, and the figures (Talts et
al. 2018, arXiv:1804.06788). Every number of a table keeps its place in
``calibration.json`` (its JSON pointer), as the estimate's report does.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from drumroll import fileio
from drumroll.errors import DrumrollError
from drumroll.inference.calibration import CHI_SQUARE_LEVEL, MIN_EXPECTED, coverage
from drumroll.quantities import QUANTITIES
from drumroll.reporting.document import (
    Block,
    BulletList,
    Code,
    Content,
    Document,
    Figure,
    Heading,
    Paragraph,
    Strong,
    Table,
    TableNote,
    content,
    number,
    plain_text,
    pointer,
)
from drumroll.reporting.plot_style import missing_glyphs_said_once

#: The outputs by key, in the order they are written.
CALIBRATION_FILES = {"json": "calibration.json", "ranks": "ranks.png",
                     "coverage": "coverage.png", "report": "report.md",
                     "report_html": "report.html"}

#: The figures: key → caption and what to look for.
FIGURES = {
    "ranks": ("Rank histograms",
              "The truth's rank among the posterior draws, per quantity, with the band each "
              "bin stays in with 99 % probability when the posterior is right (grey) and its "
              "expected count (line). A ∪ says the posterior is too narrow, a ∩ too wide, a "
              "slope that it is biased. With --audio the extractor's ranks are the outline."),
    "coverage": ("Coverage",
                 "The share of simulations whose central 50 % and 90 % intervals held the "
                 "truth, with 68 % Clopper–Pearson error bars, against the nominal rate "
                 "(dashed) and the band a calibrated coverage falls in with 99 % probability "
                 "(grey)."),
}


def _label(key: str) -> Content:
    """``α (alpha)``: the plain symbol and the key, for a table's first column."""
    q = QUANTITIES.get(key)
    return (f"{q.plain} (", Code(key), ")") if q is not None else (Code(key),)


def _unit(key: str) -> str:
    q = QUANTITIES.get(key)
    return q.unit if q is not None and q.unit else "—"


def _value(value: Any, text: str, source: str | None) -> Content:
    """A number as text with its pointer; — when it is not finite."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        return ("—",)
    if not math.isfinite(value):
        return ("—",)
    return (number(value, format(value, text).replace("-", "−"), source),)


def _flagged(shown: Content, passes: bool) -> Content:
    """``shown`` as it is, or strong with ⚠ where it fails its test."""
    return shown if passes else (Strong(shown), " ⚠")


def _coverage(c: Any, source: str) -> Content:
    """``0.91 ± 0.02`` (the error: half the 68 % Clopper–Pearson interval), strong with ⚠
    outside the 99 % band."""
    shown = number(c.rate, f"{c.rate:.2f} ± {c.error:.2f}", f"{source}/rate", error=c.error)
    return _flagged((shown,), c.inside)


def _p_value(p: Any, source: str) -> Content:
    shown = _value(p, ".2g", source)
    try:
        low = float(p) < CHI_SQUARE_LEVEL
    except (TypeError, ValueError):
        low = False
    return _flagged(shown, not low)


def quantity_table(result: Any, level: str, keys: tuple[str, ...]) -> Table:
    """The table of ``keys`` in the calibration ``level`` (``"onsets"`` or ``"audio"``)."""
    calibration = result.level(level)
    rows = []
    for key in keys:
        q = calibration.quantities[key]
        here = pointer(level, "quantities", key)
        rows.append((
            _label(key), (_unit(key),), _coverage(q.coverage_50, f"{here}/coverage_50"),
            _coverage(q.coverage_90, f"{here}/coverage_90"),
            _p_value(q.chi_square.p_value, f"{here}/chi_square/p_value"),
            _value(q.mean_z, "+.2f", f"{here}/mean_z"), _value(q.sd_z, ".2f", f"{here}/sd_z"),
            _value(q.contraction, ".3f", f"{here}/contraction"),
            ("pass",) if q.passed else (Strong(("fail",)),)))
    header = (("quantity",), ("unit",), ("50 % coverage",), ("90 % coverage",), ("χ² p",),
              ("mean z",), ("sd z",), ("contraction",), ("",))
    return Table(header, tuple(rows), (None, None, *("right",) * 6, None))


def _failure(q: Any) -> Content:
    """Why a quantity failed, in numbers."""
    c = q.coverage_90
    why = []
    if not c.inside:
        why.append(f"90 % coverage {c.rate:.2f}, outside {c.band_low:.2f} … {c.band_high:.2f}")
    if q.chi_square.p_value < CHI_SQUARE_LEVEL:
        why.append(f"ranks not uniform, χ² p = {q.chi_square.p_value:.2g}")
    return content(_label(q.key), f" ({'; '.join(why)})")


def _listed(keys: list[str] | tuple[str, ...]) -> Content:
    return content(*[(", " if i else "", _label(k)) for i, k in enumerate(keys)])


def _can_fail(level: Any) -> bool:
    """Whether the level's coverage tests can fail at all (not with one or two
    simulations: :attr:`~drumroll.inference.calibration.Coverage.can_fail`)."""
    return all(level.quantities[k].coverage_90.can_fail for k in level.parameters)


def _simulations(n: int) -> str:
    return f"{n} simulation{'' if n == 1 else 's'}"


def headline(result: Any) -> tuple[Content, ...]:
    """The verdict before any number, one paragraph each: what was calibrated, then per
    level which parameters pass and which fail."""
    settings = result.settings
    paragraphs: list[Content] = [(
        f"Simulation-based calibration (Talts et al. 2018) of {settings.n} "
        f"roll{'' if settings.n == 1 else 's'} of "
        f"{settings.n_onsets} onsets drawn from the priors of the ", Code(settings.model),
        " model and fitted as ", Code("estimate"), " fits them.")]
    for name, level in result.levels.items():
        source = ("the simulated onsets" if name == "onsets"
                  else "the onsets the extractor found in each roll's recording")
        failed = level.failed()
        untested = not _can_fail(level)
        if not failed and untested:
            verdict = content(Strong(("Not tested",)), f": with {_simulations(settings.n)} "
                              "every coverage lies inside its binomial 99 % band, whatever "
                              "the fits did; run more (--n 100 or more)")
        elif not failed:
            tested = all(level.quantities[k].chi_square.dof for k in level.parameters)
            verdict = content(Strong(("Every parameter is calibrated",)), " (",
                              _listed(level.parameters), "): its 90 % coverage lies inside "
                              "the binomial 99 % band",
                              " and its ranks pass the χ² test at 1 %" if tested else "")
        else:
            passed = [k for k in level.parameters if k not in failed]
            verdict = content(
                Strong(("Not calibrated:",)), " ",
                *[("; " if i else "", _failure(level.quantities[k]))
                  for i, k in enumerate(failed)],
                (". The other parameters pass (", _listed(passed), ")") if passed else "")
        derived_failed = level.failed(level.derived)
        derived: Content = ()
        if level.derived and not untested:
            derived = (" Derived quantities: ", "all pass." if not derived_failed
                       else content("fail: ", _listed(derived_failed), "."))
        paragraphs.append(content(f"Fitting {source}: ", verdict, ".", derived))
    if (any(q.chi_square.dof == 0 for q in result.onsets.quantities.values())
            and _can_fail(result.onsets)):
        paragraphs.append((f"{_simulations(settings.n)} {'is' if settings.n == 1 else 'are'} "
                           "too few for the χ² test of the "
                           f"ranks (it needs {2 * MIN_EXPECTED} or more): the coverage alone "
                           "decides.",))
    return tuple(paragraphs)


def headline_text(result: Any) -> str:
    """:func:`headline` as plain text, a line per paragraph (the terminal's)."""
    return "\n".join(plain_text(paragraph) for paragraph in headline(result))


def _audio_blocks(result: Any) -> tuple[Block, ...]:
    """What hearing the rolls changes: the extractor's record, the coverage side by side, and
    the coverage over the rolls it numbered right and over the others."""
    draws = [d for d in result.draws if d.hearing is not None]
    if result.audio is None or not draws:
        return ()
    n = len(draws)
    heard = [d.hearing for d in draws]
    right = [h.first == 0 and h.misnumbered == 0 for h in heard]
    fraction = sorted(h.n_heard / h.n_impacts for h in heard)
    errors = sorted(h.median_error_ms for h in heard if h.median_error_ms is not None)
    sound = ((", with the config's ", Code("[simulate]"), " sound: its ")
             if result.settings.sound == "config" else
             (", with its default sound, the config having no ", Code("[simulate]"),
              " section: its "))
    record = Paragraph((
        "Each simulated roll was also rendered as a recording (the renderer of ",
        Code("drumroll simulate"), *sound,
        "room, noise, hum and stray sounds), its onsets found by the extractor and fitted in "
        f"the same way, against the same truths. Of the {n} recordings the extractor numbered "
        f"the roll from its first impact in {sum(h.first == 0 for h in heard)}, took a sound "
        f"before the roll for its first bounce in {sum(h.first < 0 for h in heard)} (the tap "
        f"{'the [simulate] section' if result.settings.sound == 'config' else 'the sound'} "
        "puts 0.2 to 1 s before the roll, where it lands near an "
        "earlier bounce's place), and missed the first impact in "
        f"{sum(h.first > 0 for h in heard)}; {sum(not r for r in right)} rolls hold at least "
        "one onset whose number is not its impact's. It kept a median "
        f"{fraction[len(fraction) // 2]:.0%} of the impacts, each onset a median "
        f"{errors[len(errors) // 2] if errors else math.nan:.2f} ms from its impact.",))
    keys = (*result.audio.parameters, *result.audio.derived)
    rows = []
    for key in keys:
        a, b = result.onsets.quantities[key], result.audio.quantities[key]
        split = [coverage([d.audio.covered_90[key] for d, ok in zip(draws, right, strict=True)
                           if ok is want], 0.9) for want in (True, False)]
        rows.append((
            _label(key), _coverage(a.coverage_90, pointer("onsets", "quantities", key,
                                                          "coverage_90")),
            _coverage(b.coverage_90, pointer("audio", "quantities", key, "coverage_90")),
            *(((number(c.rate, f"{c.rate:.2f}"), f" ({c.n})") if c.n else ("—",))
              for c in split),
            _value(a.sd_z, ".2f", pointer("onsets", "quantities", key, "sd_z")),
            _value(b.sd_z, ".2f", pointer("audio", "quantities", key, "sd_z"))))
    header = (("quantity",), ("90 % coverage, onsets",), ("90 % coverage, heard",),
              ("heard, numbered right",), ("heard, misnumbered",), ("sd z, onsets",),
              ("sd z, heard",))
    note = TableNote(("The same rolls fitted twice: from their simulated onsets, and from "
                      "what the extractor found in their recordings (heard); then the heard "
                      "fits split by whether every onset kept its impact's number (the "
                      "rolls in brackets). ⚠: outside the 99 % band of a calibrated "
                      "coverage.",))
    return (Heading(2, ("From recordings: what the extractor changes",)), record,
            Table(header, tuple(rows), (None, *("right",) * 6), notes=(note,)),
            *_by_jitter(keys, [d for d, ok in zip(draws, right, strict=True) if ok]))


#: Fewest rolls in each third of :func:`_by_jitter`'s split.
_MIN_PER_THIRD = 10


def _by_jitter(keys: tuple[str, ...], draws: list[Any]) -> tuple[Block, ...]:
    """The rolls the extractor numbered right, in thirds by their true onset jitter: the heard
    fits' coverage beside the same rolls' fits of their simulated onsets. Where a roll's onsets
    scatter by milliseconds the extractor's choice and timing of bounces, which lean on the
    flight law, can narrow the heard fits' bars; the split shows from which jitter on."""
    jitter = np.array([d.truth.get("jitter_ms", math.nan) for d in draws], float)
    if jitter.size < 3 * _MIN_PER_THIRD or not np.all(np.isfinite(jitter)) \
            or np.ptp(jitter) == 0:
        return ()
    order = np.argsort(jitter, kind="stable")
    thirds = [order[part] for part in np.array_split(np.arange(order.size), 3)]
    rows = []
    for key in keys:
        cells = []
        for members in thirds:
            heard = coverage([draws[i].audio.covered_90[key] for i in members
                              if key in draws[i].audio.covered_90], 0.9)
            fitted = coverage([draws[i].onsets.covered_90[key] for i in members
                               if key in draws[i].onsets.covered_90], 0.9)
            if not heard.n:
                cells.append(("—",))
                continue
            shown = f"{heard.rate:.2f} ({fitted.rate:.2f})" if fitted.n else f"{heard.rate:.2f}"
            cells.append(_flagged((shown,), heard.inside))
        rows.append((_label(key), *cells))
    header = (("quantity",), *((f"σ {jitter[m].min():.2g} to {jitter[m].max():.2g} ms "
                                 f"({m.size} rolls)",) for m in thirds))
    note = TableNote(("90 % coverage of the heard fits of the rolls numbered right, in thirds "
                      "by the jitter their onsets were simulated with; in brackets the same "
                      "rolls fitted from their simulated onsets. ⚠: the heard coverage outside "
                      "the 99 % band for that many rolls. Bars that hold at small jitter and "
                      "not at large are the extractor's doing: it finds and times bounces with "
                      "the flight law's help, which a roll whose onsets scatter by "
                      "milliseconds keeps only loosely.",))
    return (Paragraph(("The rolls numbered right, by their jitter:",)),
            Table(header, tuple(rows), (None, "right", "right", "right"), notes=(note,)))


def _method(result: Any) -> BulletList:
    settings = result.settings
    sampler = settings.sampler
    rejected = result.rejected
    n_rejected = sum(rejected.values())
    items: list[Content] = [
        ("Config: ", Code(result.config_path or "(given in Python)"), ", model ",
         Code(settings.model), ", ", Code(settings.noise), " onset noise. Each simulation "
         "draws θ from the priors (a draw the physics forbids is drawn again: the prior the fit "
         f"uses is truncated to those points), simulates {settings.n_onsets} onsets through "
         "the model's forward model with its timing noise (and restitution scatter and contact "
         "time where the config has them), every bounce heard, and fits them with ",
         Code("estimate"), f"'s sampler settings ({sampler.get('walkers')} walkers until bulk "
         f"and tail ESS ≥ {sampler.get('target_ess', 0):.0f} and R-hat < "
         f"{sampler.get('max_r_hat')}, at most {sampler.get('max_steps')} steps). The compared "
         "models and the evidence are not computed (nor, with ", Code("missed_first"), ", the "
         "renumbered fits' evidences): they serve the model comparison and leave the main "
         "posterior unchanged."),
        (f"Ranks: the truth among {settings.rank_draws} posterior draws chosen at random among "
         "draws one autocorrelation time apart (nearly independent), histogram bins dividing "
         "the rank values evenly; coverage: central intervals of all the stored draws (at most "
         "3,000); z = (posterior mean − truth) / posterior sd; contraction = 1 − posterior "
         "variance / prior variance (T0's prior: its flat 1 s window).",),
        (f"Seed {settings.seed}; simulation i's seeds derive from the seed and i alone. ",
         number(result.seconds, f"{result.seconds:.0f}", "/seconds"), " s of wall time, ",
         number(result.cpu_seconds, f"{result.cpu_seconds:.0f}", "/cpu_seconds"),
         " s summed over the simulations; drumroll ", result.versions.get("drumroll", "?"),
         "."),
    ]
    if n_rejected:
        reasons = "; ".join(f"{reason}: {count}" for reason, count in rejected.items())
        items.append((
            f"{n_rejected} of {result.attempts} parameter draws were made again ({reasons}). "
            "A roll refused for its data alone (onsets out of time order, too few heard, an "
            "extractor too slow) leaves the calibration valid, as the posterior given data "
            "that pass a check on the data is the posterior given the data; the rolls "
            "calibrated are those that pass.",))
    for name, level in result.levels.items():
        if level.unconverged or level.inadequate:
            items.append((f"Fits of the {name}: {level.unconverged} stopped at the step limit "
                          f"before the ESS and R-hat targets; {level.inadequate} were flagged "
                          "by the residual checks (the model is the truth here: the checks' "
                          "false alarms).",))
    k = len(result.onsets.parameters)
    items.append((f"With {k} parameters, each tested twice at 1 %, a calibrated inference "
                  f"fails at least one test in about {1 - 0.99 ** (2 * k):.0%} of runs (less, "
                  "as the tests are correlated): one failure near the band's edge is weak "
                  "evidence; a failure by far, or a shape in the ranks, is not.",))
    return BulletList(tuple(items))


def calibration_document(result: Any, figures: dict[str, Figure] | None = None) -> Document:
    """The report of a :class:`~drumroll.calibration.CalibrationResult`: the headline, the
    parameters' table, the derived quantities', the extractor's (with audio), how to read it,
    how it was made, and ``figures`` (key of :data:`FIGURES` → its
    :class:`~drumroll.reporting.document.Figure`)."""
    onsets = result.onsets
    title = f"Calibration of the {result.settings.model} model"
    blocks: list[Block] = [Heading(1, (title,)),
                           *(Paragraph(p) for p in headline(result)),
                           Heading(2, ("Parameters",)),
                           quantity_table(result, "onsets", onsets.parameters)]
    if onsets.derived:
        blocks += [Heading(2, ("Derived quantities",)),
                   Paragraph(("Functions of the parameters, calibrated as the parameters are "
                              "(any function of θ has uniform ranks when the posterior is "
                              "right).",)),
                   quantity_table(result, "onsets", onsets.derived)]
    blocks += _audio_blocks(result)
    blocks += [Heading(2, ("How to read it",)), Paragraph((
        "Coverage is the share of simulations whose central interval held the truth, ± half "
        "its 68 % Clopper–Pearson interval; ⚠ marks a coverage outside the band a calibrated "
        "posterior's falls in with 99 % probability (binomial). χ² p tests that the ranks of "
        "the truth among the posterior draws are uniform (Talts et al. 2018); ⚠ below 0.01. "
        "Mean z near 0 and sd z near 1 say the posterior mean is unbiased and its sd honest; "
        "a ∪-shaped rank histogram says the posterior is too narrow, a ∩ too wide, a slope "
        "biased. Contraction near 1: the data, not the prior, set the parameter; near 0: the "
        "prior does (its coverage then says little about the data).",))]
    blocks += [Heading(2, ("How it was made",)), _method(result)]
    if figures:
        blocks += [Heading(2, ("Figures",)), *(figures[k] for k in FIGURES if k in figures)]
    return Document(title, tuple(blocks))


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
    """Write ``calibration.json``, ``ranks.png``, ``coverage.png``, ``report.md`` and
    ``report.html`` into ``out_dir`` together: all of them or, if one fails (a full disk),
    none, and a folder this made is removed again.

    Returns
    -------
    dict
        Output key (:data:`CALIBRATION_FILES`) → path.
    """
    from drumroll.reporting.calibration_plots import draw_coverage, draw_ranks
    from drumroll.reporting.plot_style import png_bytes, style
    from drumroll.reporting.report_files import document_writers

    out_dir = check_calibration_outputs(out_dir, overwrite=overwrite)
    paths = {key: out_dir / name for key, name in CALIBRATION_FILES.items()}
    with missing_glyphs_said_once(CALIBRATION_FILES["ranks"]), style():
        # Drawn once: the PNG files and the HTML page's embedded figures are these bytes.
        pngs = {"ranks": png_bytes(draw_ranks(result)),
                "coverage": png_bytes(draw_coverage(result))}
    figures = {key: Figure(FIGURES[key][0], FIGURES[key][1], path=paths[key], png=pngs[key])
               for key in FIGURES}
    text = json.dumps(result.to_json(), indent=1, ensure_ascii=False) + "\n"
    created = not out_dir.exists()
    try:
        out_dir.mkdir(exist_ok=True)
    except OSError as exc:
        if fileio.no_space(exc):
            raise fileio.no_space_error(out_dir, exc) from None
        raise
    written = False
    try:
        fileio.write_together({
            paths["json"]: lambda tmp: tmp.write_text(text, encoding="utf-8"),
            paths["ranks"]: lambda tmp: tmp.write_bytes(pngs["ranks"]),
            paths["coverage"]: lambda tmp: tmp.write_bytes(pngs["coverage"]),
            **document_writers(paths["report"], calibration_document(result, figures)),
        }, overwrite=overwrite)
        written = True
    finally:
        if created and not written:  # a folder this made, left empty: not left behind
            with contextlib.suppress(OSError):
                out_dir.rmdir()
    return paths
