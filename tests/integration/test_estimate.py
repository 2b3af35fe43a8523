"""``estimate`` end to end on simulated onsets with known truth (no mocks)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from configs import BALL_CONFIG, PAPER_STICK
from drumroll.cli.main import estimate_main, main
from drumroll.inference.evidence import Evidence
from drumroll.inference.likelihood import OnsetData, gaussian_marginal
from drumroll.inference.loo import conditional_pointwise
from drumroll.physics import StickGeometry, bounce_sequence
from drumroll.pipeline import estimate, evidence_summary
from drumroll.reporting.outputs import load_posteriors
from paths import DATA

STICK = StickGeometry("cylinder-cone", 0.348, 0.060, 0.0075)



def stick_config(compare: str, evidence: bool | str, height: float, sigma_h: float = 3.0) -> str:
    evidence = f'"{evidence}"' if isinstance(evidence, str) else str(evidence).lower()
    return textwrap.dedent(f"""\
        model = "pendulum"
        compare = [{compare}]

        """) + PAPER_STICK + textwrap.dedent(f"""\

        [priors]
        alpha = {{ dist = "uniform", low = 0.5, high = 1.0 }}
        pivot_mm = {{ dist = "normal", mu = 131, sigma = 2 }}
        height_mm = {{ dist = "normal", mu = {height}, sigma = {sigma_h} }}
        jitter_ms = {{ dist = "loguniform", low = 0.01, high = 10 }}

        [sampler]
        evidence = {evidence}
        """)


def simulated_onsets(path: Path, times: np.ndarray) -> Path:
    path.write_text("\n".join(f"{t:.7f}" for t in times) + "\n")
    return path


def drop_times(height_m: float, jitter_s: float, n: int, seed: int, alpha: float = 0.88,
               release_speed: float = 0.0) -> np.ndarray:
    b = bounce_sequence("pendulum", alpha=alpha, pivot=0.131, height=height_m,
                        release_speed=release_speed, stick=STICK, n_flights=n - 1)
    rng = np.random.default_rng(seed)
    return 0.5 + b.impacts[0] + rng.normal(0.0, jitter_s, n)


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    """A bouncing ball (α = 0.7, t_B = 0.6 s, 1 ms jitter) fitted with the power law."""
    tmp = tmp_path_factory.mktemp("ball")
    rng = np.random.default_rng(3)
    flights = 0.6 * 0.7 ** np.arange(1, 12)
    times = 0.3 + np.concatenate([[0.0], np.cumsum(flights)]) + rng.normal(0, 1e-3, 12)
    source = simulated_onsets(tmp / "ball.txt", times)
    config = tmp / "ball.toml"
    config.write_text(BALL_CONFIG)
    out = tmp / "out"
    code = main(["estimate", str(source), "--prior", str(config), "--out", str(out), "-q"])
    return code, out, source, config


def test_bouncing_ball_with_power_law_and_no_stick(ball):
    code, out, _, _ = ball
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    alpha = summary["parameters"]["alpha"]
    t_b = summary["parameters"]["t_b"]
    assert alpha["hdi_low"] < 0.7 < alpha["hdi_high"]
    assert abs(alpha["mean"] - 0.7) < 0.01
    assert t_b["hdi_low"] < 0.6 < t_b["hdi_high"]
    assert summary["model"] == "powerlaw" and summary["n_onsets"] == 12
    for key in ("mean", "sd", "median", "hdi_low", "hdi_high", "hdi_prob", "r_hat", "ess_bulk",
                "ess_tail"):
        assert key in alpha
    assert alpha["hdi_prob"] == 0.9
    assert alpha["r_hat"] < 1.01 and alpha["ess_bulk"] >= 400
    for name in ("report.md", "posterior.nc", "bounce_series.png", "corner.png", "trace.png",
                 "residuals.png"):
        assert (out / name).stat().st_size > 0, name
    assert not (out / "comparison.png").exists()  # one model: nothing to compare


def test_posterior_file_reopens_with_every_group(ball):
    _, out, _, _ = ball
    fits = load_posteriors(out / "posterior.nc")
    idata = fits["powerlaw"]
    for group in ("posterior", "prior", "log_likelihood", "posterior_predictive",
                  "observed_data", "sample_stats"):
        assert group in idata.groups(), group
    assert idata.log_likelihood["onset_time"].shape[-1] == 12
    # Every draw's R-hat and ESS (summary.json) travel with the thinned stored variables.
    summary = json.loads((out / "summary.json").read_text())
    for name, values in idata.posterior.data_vars.items():
        for key in ("r_hat", "ess_bulk", "ess_tail"):
            assert values.attrs[key] == pytest.approx(summary["parameters"][name][key])


def test_the_same_seed_gives_the_same_summary(ball, tmp_path):
    """Run again with the same seed: summary.json is the same byte for byte, apart from the
    seconds each stage took."""
    _, out, source, config = ball
    again = tmp_path / "again"
    assert main(["estimate", str(source), "--prior", str(config), "--out", str(again),
                 "-q"]) == 0
    first, second = (json.loads((folder / "summary.json").read_text())
                     for folder in (out, again))
    assert first.pop("seconds").keys() == second.pop("seconds").keys()
    assert first == second


def test_no_evidence_flag_overrides_a_config_that_asks_for_evidences(ball, tmp_path):
    """``--no-evidence`` on a config whose ``[sampler]`` leaves evidences on (it crashed: the
    flag wrote ``false`` into the parsed section, where "none" is what parsing leaves)."""
    _, _, source, _ = ball
    config = tmp_path / "with_evidence.toml"
    config.write_text(BALL_CONFIG.replace("evidence = false\n", ""))
    out = tmp_path / "out"
    assert main(["estimate", str(source), "--prior", str(config), "--out", str(out),
                 "--no-evidence", "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert not summary["evidence"] and "powerlaw_evidence" not in summary["seconds"]


def test_figures_drawn_while_estimating_equal_those_drawn_after(ball, tmp_path):
    """With two processes the corner and trace plots are drawn as soon as the main model is
    back, while the estimate goes on (reporting.outputs.FigureDrawer); the outputs are those
    of one process, which draws everything at the end: the same files, the same pixels."""
    from PIL import Image

    _, out, source, config = ball  # one process ([sampler] workers = 1)
    two = tmp_path / "two"
    assert main(["estimate", str(source), "--prior", str(config), "--out", str(two), "-q",
                 "--workers", "2"]) == 0
    assert sorted(p.name for p in two.iterdir()) == sorted(p.name for p in out.iterdir())
    for name in ("corner.png", "trace.png", "bounce_series.png", "residuals.png"):
        np.testing.assert_array_equal(np.asarray(Image.open(two / name)),
                                      np.asarray(Image.open(out / name)), err_msg=name)


def test_the_command_imports_neither_arviz_nor_xarray(ball, tmp_path):
    """Every output (posterior.nc, the figures, the summaries) is made without ArviZ, xarray,
    pandas and pyplot (0.7 CPU-s to import), and emcee runs without scipy.stats (0.3 CPU-s);
    the API's ``Result.idatas`` still gives ArviZ InferenceData."""
    _, _, source, config = ball
    code = ("import sys; from drumroll.cli.main import main; "
            f"status = main(['estimate', {str(source)!r}, '--prior', {str(config)!r}, "
            f"'--out', {str(tmp_path / 'out')!r}, '-q']); "
            "heavy = [m for m in ('arviz', 'xarray', 'pandas', 'corner', 'matplotlib.pyplot', "
            "'scipy.stats') "
            "if sys.modules.get(m) is not None]; assert status == 0 and not heavy, "
            "(status, heavy)")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
    assert (tmp_path / "out" / "posterior.nc").stat().st_size > 0
    result = estimate(source, config)
    import arviz as az

    assert isinstance(result.idatas["powerlaw"], az.InferenceData)
    assert result.idatas["powerlaw"].posterior["alpha"].shape == \
        result.draws["powerlaw"].posterior["alpha"].shape


def test_existing_outputs_are_kept_without_force(ball, capsys):
    code, out, source, config = ball
    before = (out / "summary.json").read_bytes()
    code = main(["estimate", str(source), "--prior", str(config), "--out", str(out), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "--force" in err and len(err.strip().splitlines()) == 1
    assert (out / "summary.json").read_bytes() == before


def test_estimate_alias_and_bad_inputs(tmp_path, capsys):
    config = tmp_path / "c.toml"
    config.write_text(BALL_CONFIG)
    for argv, fragment in [
        ([str(tmp_path / "missing.wav"), "--prior", str(config)], "no such file"),
        ([str(tmp_path), "--prior", str(config)], "directory"),
    ]:
        assert estimate_main(argv) == 2
        err = capsys.readouterr().err
        assert fragment in err and len(err.strip().splitlines()) == 1
    few = simulated_onsets(tmp_path / "few.txt", np.array([0.1, 0.5, 0.8]))
    assert estimate_main([str(few), "--prior", str(config), "--out", str(tmp_path / "o")]) == 2
    assert "at least 4" in capsys.readouterr().err


def test_alias_is_installed_and_prints_no_traceback(tmp_path):
    proc = subprocess.run([sys.executable, "-c", "from drumroll.cli.main import estimate_main;"
                           "raise SystemExit(estimate_main())", "nothing.wav", "--prior",
                           "nothing.toml"], capture_output=True, text=True, check=False)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr


def test_evidence_check_warns_only_when_the_estimates_disagree():
    nested = Evidence(log_z=10.0, log_z_err=0.3, n_calls=1000)
    entry, warning = evidence_summary(nested, Evidence(log_z=10.4, log_z_err=0.01, n_calls=0,
                                                       ess=5000.0))
    assert warning is None and entry.importance_log_z == 10.4
    assert entry.importance_ess == 5000.0
    _, warning = evidence_summary(nested, Evidence(log_z=12.0, log_z_err=0.01, n_calls=0))
    assert warning is not None and "disagree" in warning
    entry, warning = evidence_summary(nested, None)
    assert warning is None and entry.importance_log_z is None


def test_conditional_pointwise_is_the_ratio_of_marginals():
    """log p(t_i | t_-i, θ) = log p(t | θ) − log p(t_-i | θ) with T0 marginalised."""
    rng = np.random.default_rng(1)
    times = np.sort(rng.random(7)) * 2
    sigmas = rng.random(7) * 1e-3
    impacts = np.cumsum(np.r_[0, rng.random(6)])[None, :] * 0.5
    jitter = np.array([2e-3])
    data = OnsetData.from_arrays(times, sigmas)
    pointwise = conditional_pointwise(data, impacts, jitter)[0]
    full = gaussian_marginal(data, impacts, jitter)[0][0]
    for i in range(7):
        keep = np.arange(7) != i
        part = gaussian_marginal(OnsetData.from_arrays(times[keep], sigmas[keep]),
                                 impacts[:, keep], jitter)[0][0]
        assert pointwise[i] == pytest.approx(full - part, abs=1e-9)


@pytest.mark.slow
def test_pendulum_preferred_for_large_contact_angle_and_small_jitter(tmp_path):
    source = simulated_onsets(tmp_path / "big.txt", drop_times(0.150, 1e-4, 22, seed=5))
    config = tmp_path / "c.toml"
    config.write_text(stick_config('"small-angle"', evidence="nested", height=150))
    result = estimate(source, config)
    assert result.preferred == "pendulum"
    row = result.summary.comparison[0]
    assert row.elpd_loo_diff > 4 and row.log_bayes_factor > 1
    for evidence in result.summary.evidence.values():  # two independent ln Z estimates
        tolerance = 3 * math.hypot(evidence.log_z_err, evidence.importance_log_z_err)
        assert abs(evidence.log_z - evidence.importance_log_z) < tolerance
    alpha = result.parameter("alpha")
    assert alpha.hdi_low < 0.88 < alpha.hdi_high


@pytest.mark.slow
def test_no_preference_claimed_for_small_contact_angle_and_large_jitter(tmp_path):
    source = simulated_onsets(tmp_path / "small.txt", drop_times(0.036, 2e-3, 16, seed=6))
    config = tmp_path / "c.toml"
    config.write_text(stick_config('"small-angle"', evidence=True, height=36, sigma_h=1))
    result = estimate(source, config)
    assert result.preferred is None
    assert "cannot tell" in result.summary.verdict


def test_what_a_roll_cannot_tell_is_said_and_the_noise_sd_is_reported():
    """A fixed release makes t_c conditional on it (a note says so); the stick models report
    eq. 8's effective height; Student-t noise reports its sd, σ √(ν / (ν − 2))."""
    result = estimate(DATA / "table2_h80.flac", DATA / "table2_h80.toml")
    notes = " ".join(result.summary.notes)
    assert "t_c assumes the release this config fixes" in notes
    p = result.summary.parameters
    assert 76.5 < p["effective_height_mm"].mean < 78.0
    nu = 4.0  # table2_h80.toml's fixed ν
    jitter = result.fits["pendulum"].idata.posterior
    np.testing.assert_allclose(jitter["jitter_sd_ms"].values,
                               jitter["jitter_ms"].values * np.sqrt(nu / (nu - 2)), rtol=1e-12)
