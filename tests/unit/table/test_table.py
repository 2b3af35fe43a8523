"""``drumroll table``: RUNS.toml validation through the CLI, formatting, Figure 5 (no sampling)."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import drumroll.table.execute as execute
from drumroll.cli.main import main
from drumroll.errors import ConfigError
from drumroll.inference.results import (
    FlightSeries,
    ModelSummary,
    NumberingAverage,
    ObservedFlights,
    ParameterSummary,
    Summary,
)
from drumroll.table import FORMATS, format_table, load_runs
from drumroll.table.execute import Estimate, RunRow, TableResult, run_key
from drumroll.table.formatting import format_for
from drumroll.table.plot import plot_table
from drumroll.table.runs import vary_value
from paths import DATA

BASE = """
model = "pendulum"
compare = ["small-angle"]
[stick]
shape = "cylinder-cone"
length_mm = { dist = "normal", mu = 348, sigma = 1 }
tip_mm = { dist = "normal", mu = 60, sigma = 1 }
radius_mm = 7.5
[priors]
alpha = { dist = "uniform", low = 0.5, high = 1.0 }
pivot_mm = { dist = "normal", mu = 131, sigma = 2 }
height_mm = { dist = "normal", mu = 80, sigma = 3 }
jitter_ms = { dist = "loguniform", low = 0.01, high = 10 }
[sampler]
evidence = false
max_steps = 500
walkers = 16
"""


def write_onsets(path: Path, truth: str, n: int = 14, seed: int = 0) -> Path:
    """Onset times of a bundled recording's truth, with 0.1 ms of jitter."""
    times = np.array(json.loads((DATA / f"{truth}.truth.json").read_text())
                     ["model_impact_times_s"][:n])
    times += 1e-4 * np.random.default_rng(seed).standard_normal(times.size)
    path.write_text("\n".join(f"{t:.6f}" for t in times) + "\n")
    return path


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "base.toml").write_text(BASE)
    write_onsets(tmp_path / "h80.txt", "table2_h80")
    write_onsets(tmp_path / "d131.txt", "table1_d131", seed=1)
    return tmp_path


def runs_text(*runs: str, header: str = 'base = "base.toml"\nvary = "pivot_mm"\n') -> str:
    return header + "".join(runs)


RUN_H80 = '\n[[run]]\nlabel = "h80"\nsource = "h80.txt"\n'


def run_d131(keys: str = "") -> str:
    return ('\n[[run]]\nlabel = "d131"\nsource = "d131.txt"\n' + keys + '[run.priors]\n'
            'pivot_mm = { dist = "normal", mu = 131, sigma = 2 }\n')


@pytest.fixture
def no_sampling(monkeypatch):
    """Fail the test if anything gets to the sampling stage."""
    def boom(*args, **kwargs):
        raise AssertionError("sampling started")
    monkeypatch.setattr(execute, "compute_run", boom)


def cli_error(folder: Path, text: str, capsys, *extra: str) -> str:
    (folder / "runs.toml").write_text(text)
    status = main(["table", str(folder / "runs.toml"), "-q", *extra])
    err = capsys.readouterr().err.strip()
    assert status == 2, err
    assert "\n" not in err and "Traceback" not in err
    return err


@pytest.mark.parametrize(("text", "expected"), [
    (runs_text(RUN_H80, RUN_H80), "duplicate label 'h80'"),
    (runs_text(RUN_H80.replace("h80.txt", "missing.txt")), "missing.txt: no such file"),
    (runs_text(RUN_H80 + '[run.priors]\npivto_mm = 131\n'),
     "run 'h80' (the base config with this run's overrides): priors.pivto_mm: unknown key "
     "(did you mean 'pivot_mm'?)"),
    (runs_text(RUN_H80 + '[run.stick]\nlenght_mm = 350\n'), "did you mean 'length_mm'?"),
    (runs_text(RUN_H80 + 'colour = "red"\n'), "run 'h80': colour: unknown key"),
    (runs_text(RUN_H80, header='base = "base.toml"\nvary = "pivot"\n'),
     "vary: 'pivot' is not a parameter (did you mean 'pivot_mm'?)"),
    (runs_text(RUN_H80, header='base = "nope.toml"\n'), "nope.toml: no such config file"),
    (runs_text(RUN_H80, header='base = "base.toml"\nshare = ["alfa"]\n'),
     "did you mean 'alpha'?"),
    (runs_text(RUN_H80, header='base = "base.toml"\nbase = "x"\n'), "invalid TOML"),
    (runs_text(RUN_H80, header='base = "base.toml"\nvray = "pivot_mm"\n'),
     "vray: unknown key (did you mean 'vary'?)"),
    (runs_text(RUN_H80 + '[run.priors]\npivot_mm = { dist = "normal", mu = 131 }\n'),
     "priors.pivot_mm: the normal distribution needs 'sigma'"),
    ('base = "base.toml"\n', "run: no runs"),
    (runs_text(RUN_H80 + '[run.sampler]\nmax_step = 10\n'), "did you mean 'max_steps'?"),
])
def test_bad_runs_files_fail_before_sampling(folder, capsys, no_sampling, text, expected):
    err = cli_error(folder, text, capsys)
    assert expected in err
    assert err.startswith("drumroll: error: ")


def test_an_estimation_section_error_names_the_runs_file(folder):
    # In a fresh process the [sampler] section is parsed only when the runs are about to be
    # estimated; its error named the run but not the runs file.
    (folder / "runs.toml").write_text(
        runs_text(RUN_H80, header='base = "base.toml"\n[sampler]\nwalkers = "many"\n'))
    proc = subprocess.run([sys.executable, "-m", "drumroll", "table", "runs.toml", "-q",
                           "--no-cache"], cwd=folder, capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 2
    assert proc.stderr.startswith("drumroll: error: runs.toml: run 'h80'")
    assert "sampler.walkers: expected a number, got a string ('many')" in proc.stderr


def test_outputs_checked_before_sampling(folder, capsys, no_sampling):
    (folder / "table.md").write_text("mine")
    err = cli_error(folder, runs_text(RUN_H80), capsys, "-o", str(folder / "table.md"))
    assert "already exists" in err
    assert (folder / "table.md").read_text() == "mine"


@pytest.mark.parametrize("cache", ["h80.txt", "h80.txt/deeper"])
def test_a_cache_folder_that_is_a_file_is_refused_before_sampling(folder, capsys, no_sampling,
                                                                  cache):
    # Found by fuzzing the options: an internal error (FileExistsError) after every run
    # was estimated, the table lost.
    err = cli_error(folder, runs_text(RUN_H80), capsys, "--cache-dir", str(folder / cache))
    assert err == (f"drumroll: error: {folder / 'h80.txt'}: is not a directory; the cache "
                   "needs a folder (--cache-dir DIR, or --no-cache)")


def test_dask_missing_is_one_line(folder, capsys, monkeypatch, no_sampling):
    import builtins

    real_import = builtins.__import__

    def fake_import(name, *args, **kwargs):
        if name == "distributed":
            raise ImportError("no dask")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake_import)
    err = cli_error(folder, runs_text(RUN_H80), capsys, "--dask", "tcp://localhost:1")
    assert "pip install 'drumroll[dask]'" in err


def test_parsed_runs(folder):
    (folder / "runs.toml").write_text(runs_text(RUN_H80, run_d131('group = "g"\n')))
    runs = load_runs(folder / "runs.toml")
    assert [r.label for r in runs.runs] == ["h80", "d131"]
    assert runs.runs[0].raw["sampler"]["workers"] == 1
    assert runs.runs[1].group == "g"
    assert runs.cache_dir == folder / ".drumroll-cache"
    # the key follows the source's bytes and the effective config, not the label
    key = run_key(runs.runs[0])
    (folder / "runs.toml").write_text(runs_text(RUN_H80.replace('"h80"\n', '"other"\n', 1)))
    assert run_key(load_runs(folder / "runs.toml").runs[0]) == key
    (folder / "runs.toml").write_text(runs_text(RUN_H80 + "[run.sampler]\nseed = 3\n"))
    assert run_key(load_runs(folder / "runs.toml").runs[0]) != key


def test_a_base_may_leave_out_what_every_run_gives(folder):
    # "base: …: priors.pivot_mm: missing" refused this, although each run gives its own.
    (folder / "base.toml").write_text(BASE.replace(
        'pivot_mm = { dist = "normal", mu = 131, sigma = 2 }\n', ""))
    own = '[run.priors]\npivot_mm = { dist = "normal", mu = 110, sigma = 2 }\n'
    (folder / "runs.toml").write_text(runs_text(RUN_H80 + own, run_d131()))
    runs = load_runs(folder / "runs.toml")
    assert [vary_value(r, "pivot_mm") for r in runs.runs] == [(110.0, 2.0), (131.0, 2.0)]
    (folder / "runs.toml").write_text(runs_text(RUN_H80, run_d131()))
    with pytest.raises(ConfigError, match=re.escape(
            "run 'h80' (the base config with this run's overrides): priors.pivot_mm: missing")):
        load_runs(folder / "runs.toml")


def fake_row(alpha: float, t_b: float, n: int = 10, notes: tuple[str, ...] = ()) -> RunRow:
    """A table row as ``estimate`` would give it, with chosen α and t_B."""
    k = np.arange(1, n + 1)
    median = t_b * alpha**k
    flights = FlightSeries(median=tuple(median), low=tuple(median * 0.99),
                           high=tuple(median * 1.01))
    parameters = {"alpha": ParameterSummary(mean=alpha, sd=0.0102),
                  "t_b": ParameterSummary(mean=t_b, sd=0.0093)}
    summary = Summary(
        model="pendulum", n_onsets=n + 1, notes=notes, parameters=parameters,
        models={"pendulum": ModelSummary(parameters=parameters, flights=flights)},
        observed_flights=ObservedFlights(time_s=tuple(median * 1.01), err_s=(1e-3,) * n),
        verdict="undecided")
    return RunRow(summary=summary, seconds=1.0,
                  computed_t_b={"small-angle": Estimate(0.2509, 0.0061),
                                "pendulum": Estimate(0.2531, 0.0062)})


@pytest.fixture
def fake_result(folder) -> TableResult:
    (folder / "runs.toml").write_text(
        runs_text(RUN_H80 + 'group = "a"\n', run_d131('group = "b"\n'),
                  header='base = "base.toml"\nvary = "pivot_mm"\ntitle = "Table 1"\n'))
    runs = load_runs(folder / "runs.toml")
    return TableResult(runs=runs, rows=[fake_row(0.86, 0.21), fake_row(0.88, 0.26)])


def test_markdown_is_rounded_like_the_paper(fake_result):
    text = format_table(fake_result, "markdown")
    assert "| h80 | 131 ± 2 | 0.251 ± 0.006 | 0.253 ± 0.006 | 0.210 ± 0.009 | 0.860 ± 0.010 |" \
        in text
    assert text.startswith("**Table 1**")
    assert "undecided" in text


def test_csv_latex_json(fake_result):
    rows = list(csv.DictReader(io.StringIO(format_table(fake_result, "csv"))))
    assert rows[0]["pivot_mm"] == "131" and rows[0]["pivot_mm_err"] == "2"
    assert rows[1]["alpha"] == "0.880" and rows[1]["alpha_err"] == "0.010"
    assert rows[0]["preferred"] == "undecided"  # as Markdown and LaTeX say (it was blank)
    latex = format_table(fake_result, "latex")
    assert r"\toprule" in latex and r"\num{0.880 \pm 0.010}" in latex
    document = json.loads(format_table(fake_result, "json"))
    row = document["rows"][0]
    assert set(row) >= {"label", "vary", "computed_t_b", "fitted_t_b", "alpha", "preferred"}
    assert row["vary"]["value"] == 131 and row["vary"]["err"] == 2
    assert row["alpha"] == {"value": 0.86, "err": 0.0102}


def test_figure5_from_rows(fake_result, tmp_path):
    path = plot_table(fake_result, tmp_path / "fig.png")
    assert path.stat().st_size > 10_000
    with pytest.raises(Exception, match="already exists"):
        plot_table(fake_result, tmp_path / "fig.png")


@pytest.mark.parametrize("fmt", list(FORMATS.values()), ids=list(FORMATS))
def test_every_table_format_writes_every_run_and_is_chosen_by_its_suffixes(fmt, fake_result):
    text = format_table(fake_result, fmt.name)
    assert "h80" in text and "0.86" in text and "0.88" in text
    for suffix in fmt.suffixes:
        assert format_for(suffix.upper()) == fmt.name
    assert format_for(".txt") == "markdown"


def test_a_run_averaged_over_its_numberings_says_so_under_the_table(fake_result):
    average = NumberingAverage(fitted="0", probabilities={"0": 0.25, "1": 0.75}, parameters={
        "alpha": ParameterSummary(mean=0.8996, sd=0.0010),
        "t_b": ParameterSummary(mean=0.253, sd=0.017)})
    row = fake_result.rows[1]
    fake_result.rows[1] = dataclasses.replace(
        row, summary=dataclasses.replace(row.summary, numbering_average=average))
    text = format_table(fake_result, "markdown")
    assert ("Over the first onset's numberings (d131, pendulum): α = 0.8996 ± 0.0010, "
            "t_B = 0.253 ± 0.017 s (weights: 0 missed 0.25, 1 missed 0.75).") in text
    assert text.count("Over the first onset's numberings") == 1
    rows = json.loads(format_table(fake_result, "json"))["rows"]
    assert rows[0]["numbering_average"] is None
    assert rows[1]["numbering_average"]["probabilities"] == {"0": 0.25, "1": 0.75}
