"""``drumroll calibrate``: simulation-based calibration from the command line and from Python.

The slow test is issue 14's acceptance at n = 30 (the committed run, examples/output/calibrate,
is n = 200): the exact pendulum with the paper's priors, every parameter's 90 % coverage
inside its binomial 99 % band and its ranks uniform by χ² at 1 %.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

import drumroll
from configs import BALL_CONFIG
from drumroll.calibration import CalibrationResult
from drumroll.cli.main import main
from drumroll.errors import DrumrollError
from drumroll.reporting.calibration_report import CALIBRATION_FILES, write_calibration
from paths import DATA
from tests.integration.test_reports_html import Page, check_images, check_numbers

#: A ball's config whose fits take a fraction of a second (few walkers and steps): for the
#: machinery, not for calibration.
QUICK = BALL_CONFIG.replace("workers = 1\n", "walkers = 8\nmax_steps = 200\n")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    folder = tmp_path_factory.mktemp("calibrate")
    config = folder / "ball.toml"
    config.write_text(QUICK)
    return config


@pytest.fixture(scope="module")
def quick_result(quick):
    return drumroll.calibrate(quick, n=4, n_onsets=8, seed=3, workers=1)


def _without_seconds(result: CalibrationResult) -> list[dict]:
    draws = []
    for draw in result.to_json()["draws"]:
        draw.pop("seconds")
        for fit in (draw["onsets"], draw["audio"]):
            if fit is not None:
                fit.pop("seconds")
        draws.append(draw)
    return draws


def test_the_same_seed_gives_the_same_calibration_whatever_the_workers(quick, quick_result):
    again = drumroll.calibrate(quick, n=4, n_onsets=8, seed=3, workers=2)
    assert _without_seconds(again) == _without_seconds(quick_result)
    other = drumroll.calibrate(quick, n=4, n_onsets=8, seed=4, workers=2)
    assert _without_seconds(other) != _without_seconds(quick_result)


def test_dask_gives_the_same_calibration(quick, quick_result, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    out = tmp_path / "out"
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) \
            as cluster:
        status = main(["calibrate", str(quick), "--n", "4", "--onsets", "8", "--seed", "3",
                       "--dask", cluster.scheduler_address, "-o", str(out)])
    assert status == 0, capsys.readouterr().err
    result = CalibrationResult.from_json(json.loads((out / "calibration.json").read_text()))
    for draw, again in zip(result.draws, quick_result.draws, strict=True):
        assert draw.onsets.rank == again.onsets.rank
        assert draw.truth == pytest.approx(again.truth, rel=1e-12)


def test_the_result_holds_every_number_and_reads_back(quick_result, tmp_path):
    result = quick_result
    assert isinstance(result, CalibrationResult)
    assert result.settings.n == 4 and len(result.draws) == 4
    assert result.onsets.parameters == ("alpha", "t_b", "jitter_ms", "contact_ms", "t0_s")
    for draw in result.draws:
        assert set(draw.onsets.rank) >= set(result.onsets.parameters)
        assert all(0 <= r <= result.settings.rank_draws for r in draw.onsets.rank.values())
        assert draw.truth["alpha"] > 0 and draw.onsets.n_onsets == 8
    paths = write_calibration(result, tmp_path / "out")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(
        CALIBRATION_FILES.values())
    data = json.loads(paths["json"].read_text())
    back = CalibrationResult.from_json(data)
    assert back.onsets.quantities["alpha"].histogram == result.onsets.quantities[
        "alpha"].histogram
    assert back.draws[2].onsets.rank == result.draws[2].onsets.rank
    assert data["versions"]["drumroll"] == drumroll.__version__
    report = paths["report"].read_text()
    assert report.startswith("# Calibration of the powerlaw model")
    assert "| α (`alpha`) |" in report and "![Rank histograms](ranks.png)" in report
    # The HTML page: the figures embedded, every number of its tables calibration.json's.
    page = Page(paths["report_html"].read_text(encoding="utf-8"))
    assert page.scripts == 0 and len(check_images(page)) == 2
    check_numbers(page, data, minimum=20)  # 4 quantities; no χ² with 4 simulations
    with pytest.raises(DrumrollError, match="would overwrite"):
        write_calibration(result, tmp_path / "out")


@pytest.mark.parametrize(("case", "message"), [
    ("missing-config", "no such config file"),
    ("too-many", "--n: the number of simulations must lie in 1 … 10000, got 20000"),
    ("too-long", "--onsets: a simulated roll must have 4 … 400 onsets, got 500"),
    ("output-is-a-file", "exists and is not a directory"),
    ("outputs-exist", "would overwrite calibration.json"),
    ("audio-missing-hits", "simulate.hits[0]: no such file"),
])
def test_bad_input_is_one_line_exit_2_before_any_work(tmp_path, capsys, case, message):
    config = tmp_path / "ball.toml"
    config.write_text(QUICK)
    out = tmp_path / "out"
    argv = ["calibrate", str(config), "-o", str(out), "-q"]
    if case == "missing-config":
        argv[1] = str(tmp_path / "missing.toml")
    elif case == "too-many":
        argv += ["--n", "20000"]
    elif case == "too-long":
        argv += ["--onsets", "500"]
    elif case == "output-is-a-file":
        out.write_text("mine\n")
    elif case == "outputs-exist":
        out.mkdir()
        (out / "calibration.json").write_text("{}\n")
    elif case == "audio-missing-hits":
        config.write_text(QUICK + '\n[simulate]\nalpha = 0.9\npivot_mm = 131\nheight_mm = 80\n'
                          'hits = ["nowhere.flac"]\n')
        argv.append("--audio")
    started = time.perf_counter()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("drumroll: error: ") and message in err, err
    assert time.perf_counter() - started < 20  # before any simulation was fitted
    if case not in ("output-is-a-file", "outputs-exist"):
        assert not out.exists()


def test_a_scatter_under_student_t_noise_calibrates_from_the_command_line(tmp_path):
    """Student-t noise with a scattering restitution (its walk and T0 integrated out by
    Laplace's method): every fit ranks its truths among the same number of draws, however
    few the quick sampler stores (a fit whose drawn offset left it a draw short once stopped
    the run as an internal error)."""
    config = tmp_path / "ball.toml"
    config.write_text(QUICK.replace(
        "[sampler]", 'restitution_scatter = { dist = "halfnormal", sigma = 0.01 }\n\n'
        '[likelihood]\nnoise = "student-t"\n\n[sampler]'))
    out = tmp_path / "out"
    assert main(["calibrate", str(config), "--n", "6", "--onsets", "8", "-o", str(out),
                 "-q"]) == 0
    data = json.loads((out / "calibration.json").read_text())
    assert {d["onsets"]["rank_draws"] for d in data["draws"]} == {99}
    assert {"alpha", "restitution_scatter"} <= set(data["onsets"]["parameters"])


def test_usage_errors_exit_2(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["calibrate", "x.toml", "--onsets", "3"])
    assert stop.value.code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if ": error: " in line]
    assert len(errors) == 1 and "must be at least 4" in errors[0]


def test_sigterm_stops_the_simulations_and_keeps_nothing(tmp_path):
    """SIGTERM while the simulations are fitted in two worker processes: one line, exit 143,
    no process left, no output folder."""
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "drumroll", "calibrate", str(DATA / "table2_h80.toml"), "--n",
         "50", "--workers", "2", "-o", str(out)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    time.sleep(6)
    proc.send_signal(signal.SIGTERM)
    err = proc.stderr.read()
    assert proc.wait(timeout=60) == 143, err
    assert err.strip().splitlines()[-1] == "drumroll: terminated; no partial output was kept"
    assert "Traceback" not in err
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        pytest.fail("processes of the command still run after it ended")
    assert not out.exists()


@pytest.mark.slow
def test_the_exact_pendulum_with_the_paper_s_priors_is_calibrated(tmp_path, capsys):
    """Issue 14's acceptance at n = 30: every parameter's 90 % coverage inside the binomial
    99 % band, its ranks uniform by χ² at 1 %."""
    out = tmp_path / "calibration"
    code = main(["calibrate", str(DATA / "table2_h80.toml"), "--n", "30", "--workers", "2",
                 "-o", str(out), "-q"])
    printed = capsys.readouterr().out
    assert code == 0
    result = CalibrationResult.from_json(json.loads((out / "calibration.json").read_text()))
    assert result.onsets.parameters == ("alpha", "pivot_mm", "height_mm", "stick_length_mm",
                                        "stick_tip_mm", "jitter_ms", "contact_ms", "t0_s")
    for key in result.onsets.parameters:
        q = result.onsets.quantities[key]
        assert q.coverage_90.inside, (key, q.coverage_90)
        assert q.chi_square.p_value >= 0.01, (key, q.chi_square)
        assert abs(q.mean_z) < 0.6 and 0.6 < q.sd_z < 1.5, (key, q.mean_z, q.sd_z)
    assert result.onsets.unconverged == 0
    assert "Every parameter is calibrated" in printed
    assert (out / "ranks.png").stat().st_size > 10_000


@pytest.mark.slow
def test_audio_calibration_hears_every_roll(tmp_path):
    result = drumroll.calibrate(DATA / "table2_h80.toml", n=2, audio=True, workers=2)
    assert result.audio is not None
    assert set(result.audio.parameters) == set(result.onsets.parameters)
    for draw in result.draws:
        assert draw.hearing.n_impacts == 16 and draw.hearing.n_heard >= 4
        # The fit holds every onset heard, less a first one the estimate took for a sound
        # before the roll, and only where the first onset is no impact (draw 0: the tap the
        # [simulate] section puts before the roll).
        dropped = draw.hearing.n_heard - draw.audio.n_onsets
        assert dropped == 0 or (dropped == 1 and draw.hearing.first < 0)
        assert draw.audio_t0_s is not None
    write_calibration(result, tmp_path / "out")
    assert "## From recordings: what the extractor changes" in (
        tmp_path / "out" / "report.md").read_text()
