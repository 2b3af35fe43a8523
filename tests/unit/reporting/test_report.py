"""report.md: parameter rows rounded to their errors, comparison, diagnostics, figure links."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from drumroll.errors import DrumrollError
from drumroll.inference.results import ParameterSummary, Summary
from drumroll.reporting.numbers import format_value_error
from drumroll.reporting.report import format_estimate, render_report, write_report


def _stats(mean: float, sd: float, r_hat: float = 1.002, ess: float = 1500.0) -> dict:
    return {"mean": mean, "sd": sd, "median": mean, "hdi_low": mean - 1.645 * sd,
            "hdi_high": mean + 1.645 * sd, "hdi_prob": 0.9, "r_hat": r_hat,
            "ess_bulk": ess, "ess_tail": ess * 1.2}


@pytest.fixture()
def summary() -> Summary:
    return Summary.from_json({
        "model": "pendulum", "n_onsets": 21,
        "parameters": {
            "t_b": _stats(0.25311, 0.00052),
            "alpha": _stats(0.8612, 0.0123),
            "pivot_mm": _stats(131.24, 1.31, r_hat=1.04, ess=180.0),
            "jitter_ms": _stats(0.081, 0.013),
            "theta_c_deg": _stats(16.51, 0.15),
            "t0_s": {"mean": 1.234, "sd": 0.0, "median": 1.234, "hdi_low": math.nan,
                     "hdi_high": math.nan, "hdi_prob": 0.9, "r_hat": math.nan,
                     "ess_bulk": None, "ess_tail": None},
        },
        "comparison": [
            {"model": "small-angle", "elpd_loo_diff": 63.14, "elpd_loo_diff_se": 6.77,
             "log_bayes_factor": 55.2, "log_bayes_factor_err": 0.4},
            {"model": "powerlaw", "elpd_loo_diff": 62.98, "elpd_loo_diff_se": 6.75,
             "log_bayes_factor": None, "log_bayes_factor_err": None},
        ],
        "preferred": "pendulum",
        "verdict": "The exact pendulum fits the curvature the small-angle model misses.",
        "diagnostics": {
            "pendulum": {"converged": False, "n_steps": 3000, "tau_max": 72.3,
                         "acceptance": 0.34,
                         "warnings": ["chain shorter than 50 autocorrelation times | rerun"]},
            "powerlaw": {"converged": True, "n_steps": 1500, "tau_max": 15.0,
                         "acceptance": 0.44, "warnings": []},
        },
        "onsets": [{"time_s": 1.2, "sigma_s": 1e-4, "bounce": 0},
                   {"time_s": 1.45, "sigma_s": 1e-4, "bounce": 1},
                   {"time_s": 1.65, "sigma_s": 0.0, "bounce": 2}],
        "config": {"model": "pendulum", "stick": {"length_mm": 348.0}},
        "version": "0.1.0", "source": "/recordings/roll.flac",
    })


@pytest.fixture()
def figures(tmp_path: Path) -> dict[str, Path]:
    names = ("bounce_series", "corner", "trace", "residuals", "comparison", "onsets")
    out = {}
    for name in names:
        (tmp_path / f"{name}.png").write_bytes(b"\x89PNG\r\n\x1a\n")
        out[name] = tmp_path / f"{name}.png"
    return out


def test_report_has_title_table_rows_comparison_and_figure_links(summary, figures, tmp_path):
    path = write_report(tmp_path / "report.md", summary, figures)
    text = path.read_text(encoding="utf-8")
    assert text.startswith("# Drumroll estimate: roll.flac\n")
    assert "21 onsets" in text and "drumroll 0.1.0" in text
    # parameter rows: symbol and unit, mean ± sd rounded by the lead's rule, interval alike
    alpha_row = next(line for line in text.splitlines() if line.startswith("| α |"))
    assert format_value_error(0.8612, 0.0123) in alpha_row  # 0.861 ± 0.012
    assert "0.841 … 0.881" in alpha_row
    assert "| 1.0020 |" in alpha_row and "1500 / 1800" in alpha_row
    assert "| d (mm) |" in text and "131.2 ± 1.3" in text and "129.1 … 133.4" in text
    assert "| t_B (s) |" in text and "0.2531 ± 0.0005" in text
    assert "| σ (ms) |" in text and "| θ_C (deg) |" in text
    pivot_row = next(line for line in text.splitlines() if line.startswith("| d (mm) |"))
    assert "⚠" in pivot_row  # R-hat 1.04 and ESS 180 flagged
    # α comes before t_B comes before d, whatever the dict order
    assert text.index("| α |") < text.index("| t_B (s) |") < text.index("| d (mm) |")
    # comparison and verdict
    assert "| small-angle pendulum (`small-angle`) | 63 ± 7 | 55.2 ± 0.4 |" in text
    assert "| power law (`powerlaw`) | 63 ± 7 | — |" in text
    assert "0 (reference)" in text
    assert "**Preferred model:** exact pendulum" in text
    assert summary.verdict in text
    # diagnostics in plain words, pipes escaped
    assert "**not converged**" in text and "longest autocorrelation time 72 steps" in text
    assert "⚠ chain shorter than 50 autocorrelation times | rerun" in text
    # figures with relative links
    for name, caption in (("bounce_series", "Bounce series"), ("corner", "Posterior"),
                          ("trace", "Sampler trace"), ("residuals", "Onset residuals"),
                          ("comparison", "Model comparison"), ("onsets", "Detected onsets")):
        assert f"![{caption}]({name}.png)" in text
    assert str(tmp_path) not in text
    # details
    assert "| 1 | 1.450000 | 250.000 | 0.100 |" in text
    assert '"length_mm": 348.0' in text


def test_links_are_relative_to_the_report_folder(summary, figures, tmp_path):
    sub = tmp_path / "report"
    sub.mkdir()
    text = write_report(sub / "report.md", summary, figures).read_text(encoding="utf-8")
    assert "![Bounce series](../bounce_series.png)" in text


def test_existing_report_is_not_overwritten(summary, figures, tmp_path):
    path = tmp_path / "report.md"
    path.write_text("keep me", encoding="utf-8")
    with pytest.raises(DrumrollError, match="already exists"):
        write_report(path, summary, figures)
    assert path.read_text(encoding="utf-8") == "keep me"
    write_report(path, summary, figures, overwrite=True)
    assert path.read_text(encoding="utf-8").startswith("# Drumroll estimate")
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_minimal_summary_still_renders():
    text = render_report(Summary(model="powerlaw"))
    assert "# Drumroll estimate" in text
    assert "Only one model was fitted" in text
    assert "No sampler diagnostics" in text


@pytest.mark.parametrize(("stats", "expected"), [
    (_stats(0.2509, 0.0061), ("0.251 ± 0.006", "0.241 … 0.261")),
    ({"mean": 1234.0, "sd": 56.0, "hdi_low": 1140.0, "hdi_high": 1330.0},
     ("1230 ± 60", "1140 … 1330")),
    ({"mean": -0.5, "sd": 0.1, "hdi_low": -0.66, "hdi_high": -0.34},
     ("−0.50 ± 0.10", "−0.66 … −0.34")),
    ({"mean": 2.0, "sd": 0.0, "hdi_low": 2.0, "hdi_high": 2.0}, ("2", "2 … 2")),
    ({"mean": math.nan, "sd": 0.1}, ("—", "—")),
])
def test_format_estimate(stats, expected):
    assert format_estimate(ParameterSummary.from_json(stats)) == expected


def test_a_round_off_error_is_no_error():
    """A fixed t_B computed through the model spreads by ~1e-17 s: it is given alone, not as
    0.199999999999999983 ± 0.000000000000000028."""
    assert format_value_error(0.2, 2.8e-17) == "0.2"
    assert format_value_error(0.2, 2e-10) == "0.20000000000 ± 0.00000000020"
    assert format_value_error(0.2509, 0.0061) == "0.251 ± 0.006"


def test_a_numbering_average_is_given_after_the_result_and_after_the_table(summary):
    from dataclasses import replace

    from drumroll.inference.results import NumberingAverage

    average = NumberingAverage.from_json({
        "fitted": "0", "probabilities": {"stray": 0.7, "0": 0.3},
        "parameters": {key: {**_stats(mean, sd), "r_hat": None, "ess_bulk": None,
                             "ess_tail": None}  # a mixture has neither
                       for key, mean, sd in (("alpha", 0.94444, 0.00017),
                                             ("t_b", 0.186, 0.005))}})
    text = render_report(replace(summary, numbering_average=average))
    lines = text.splitlines()
    result = next(i for i, line in enumerate(lines) if line.startswith("**Result:**"))
    assert lines[result + 2].startswith(
        "**Over the first onset's numberings:** α = 0.94444 ± 0.00017, t_B = 0.186 ± 0.005 s "
        "(weights: first onset no impact 0.70, 0 missed 0.30). No numbering is clearly "
        "preferred: the numbers above, the tables and the figures take the first onset as "
        "impact 0;")
    section = lines.index("### Averaged over the first onset's numberings")
    assert section > lines.index("## Parameters (exact pendulum)")
    rows = [line for line in lines[section:] if line.startswith("| α |")]
    assert "0.94444 ± 0.00017" in rows[0] and "| — |" in rows[0]
    assert "## Averaged" not in render_report(summary) and "numberings" not in \
        render_report(summary)
