"""Figures of ``drumroll estimate``: every file written, valid, sensible, never overwritten.

The InferenceData are synthetic (``az.from_dict`` with the groups the pipeline builds), small
and seeded, so the whole module runs in a few seconds without a sampler.
"""

from __future__ import annotations

import os
import struct
import warnings
from pathlib import Path

import arviz as az
import matplotlib
import numpy as np
import pytest

from drumroll.errors import DrumrollError
from drumroll.reporting import plot_style
from drumroll.reporting.bounce_series import observed_flights
from drumroll.reporting.comparison_plot import plot_comparison
from drumroll.reporting.corner_plot import corner_parameters, draw_corner, quantile_title
from drumroll.reporting.figures import FIGURE_FILES, loo_comparison, write_figures
from drumroll.reporting.residuals import lag_one_correlation, onset_residuals
from drumroll.reporting.trace_plot import plot_trace

matplotlib.use("Agg")

N_ONSETS = 14
TRUE_T0 = 1.234
#: A slight departure from a geometric series, as the exact pendulum shows.
CURVATURE = 0.01


def _flights(t_b: np.ndarray, alpha: np.ndarray, curvature: float) -> np.ndarray:
    k = np.arange(1, N_ONSETS)
    power = alpha[..., None] ** k
    return t_b[..., None] * power * (1 + curvature * power)


def make_idata(model: str, observed: np.ndarray, sigmas: np.ndarray, seed: int,
               n_chain: int = 4, n_draw: int = 40, tau_attrs: bool = True) -> az.InferenceData:
    """A small InferenceData with every group of the pipeline's output."""
    rng = np.random.default_rng(seed)
    shape = (n_chain, n_draw)
    curvature = CURVATURE if model == "pendulum" else 0.0
    jitter = 0.1 if model == "pendulum" else 0.6
    posterior = {
        "alpha": 0.88 + 1e-5 * rng.standard_normal(shape),
        "jitter_ms": np.abs(jitter + 0.1 * jitter * rng.standard_normal(shape)),
        "t0_s": TRUE_T0 + 5e-5 * rng.standard_normal(shape),
    }
    if model == "powerlaw":
        posterior["t_b"] = 0.25 + 2e-5 * rng.standard_normal(shape)
        sampled = ["alpha", "t_b", "jitter_ms"]
    else:
        posterior["pivot_mm"] = 131 + rng.standard_normal(shape)
        posterior["height_mm"] = 80 - 0.8 * (posterior["pivot_mm"] - 131) \
            + 0.5 * rng.standard_normal(shape)
        posterior["t_b"] = 0.25 + 1e-5 * (posterior["pivot_mm"] - 131)
        posterior["t_c"] = posterior["t_b"] / 2
        posterior["theta_c_deg"] = 16.5 + 0.1 * rng.standard_normal(shape)
        posterior["release_speed_m_s"] = np.zeros(shape)  # held fixed: must be skipped
        sampled = ["alpha", "pivot_mm", "height_mm", "jitter_ms", "release_speed_m_s"]
    flights = _flights(posterior["t_b"], posterior["alpha"], curvature)
    mean = posterior["t0_s"][..., None] + np.concatenate(
        (np.zeros((*shape, 1)), np.cumsum(flights, axis=-1)), axis=-1)
    scale = np.sqrt((posterior["jitter_ms"][..., None] * 1e-3) ** 2 + sigmas**2)
    replicated = mean + scale * rng.standard_normal(mean.shape)
    log_lik = -0.5 * ((observed - mean) / scale) ** 2 - np.log(scale * np.sqrt(2 * np.pi))
    prior = {k: v.reshape(1, -1) + rng.standard_normal((1, v.size)) * np.std(v)
             for k, v in posterior.items()}
    idata = az.from_dict(
        posterior=posterior,
        posterior_predictive={"onset_time": replicated, "flight_time_model": flights},
        log_likelihood={"onset_time": log_lik},
        observed_data={"onset_time": observed},
        constant_data={"onset_sigma_s": sigmas},
        prior=prior,
        sample_stats={"lp": log_lik.sum(axis=-1)},
        coords={"onset": np.arange(N_ONSETS), "flight": np.arange(1, N_ONSETS)},
        dims={"onset_time": ["onset"], "flight_time_model": ["flight"],
              "onset_sigma_s": ["onset"]},
        attrs={"model": model},
    )
    if tau_attrs:
        idata.sample_stats.attrs.update({"tau_steps": [20.0] * len(sampled),
                                         "tau_parameters": sampled, "burn": 100, "thin": 5,
                                         "n_steps": 300, "acceptance": 0.4, "converged": 1})
    return idata


@pytest.fixture(scope="module")
def observed() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1)
    flights = _flights(np.array(0.25), np.array(0.88), CURVATURE)
    times = TRUE_T0 + np.concatenate(([0.0], np.cumsum(flights)))
    sigmas = np.full(N_ONSETS, 5e-5)
    sigmas[3] = 0.0
    return times + 1e-4 * rng.standard_normal(N_ONSETS), sigmas


@pytest.fixture(scope="module")
def idatas(observed) -> dict[str, az.InferenceData]:
    times, sigmas = observed
    return {"pendulum": make_idata("pendulum", times, sigmas, 2),
            "small-angle": make_idata("small-angle", times, sigmas, 3, tau_attrs=False),
            "powerlaw": make_idata("powerlaw", times, sigmas, 4)}


@pytest.fixture(scope="module")
def written(idatas, tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("figures")
    return write_figures(idatas, "pendulum", out, None,
                         truths={"alpha": 0.88, "pivot_mm": 131.0, "not_a_parameter": 1.0})


def png_size(path: Path) -> tuple[int, int]:
    """Width and height from a PNG header (fails if the file is not a PNG)."""
    data = path.read_bytes()[:24]
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path.name} is not a PNG"
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_every_figure_is_written_as_a_sensible_png(written):
    assert set(written) == set(FIGURE_FILES)
    for key, path in written.items():
        assert path.name == FIGURE_FILES[key]
        assert path.stat().st_size > 10_000, f"{path.name} is suspiciously small"
        width, height = png_size(path)
        assert 500 <= width <= 3000 and 300 <= height <= 3000, (path.name, width, height)
    # no temporary files left behind
    assert sorted(p.name for p in next(iter(written.values())).parent.iterdir()) == \
        sorted(FIGURE_FILES.values())


def test_existing_figures_are_not_overwritten(idatas, written):
    out = next(iter(written.values())).parent
    before = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in out.iterdir()}
    with pytest.raises(DrumrollError, match="already exists"):
        write_figures(idatas, "pendulum", out, None)
    after = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in out.iterdir()}
    assert before == after


def test_single_plot_refuses_then_overwrites_when_asked(idatas, tmp_path):
    path = tmp_path / "trace.png"
    path.write_bytes(b"old")
    with pytest.raises(DrumrollError):
        plot_trace(idatas["powerlaw"], path)
    assert path.read_bytes() == b"old"
    plot_trace(idatas["powerlaw"], path, overwrite=True)
    png_size(path)


def test_unknown_main_model_and_missing_folder_are_user_errors(idatas, tmp_path):
    with pytest.raises(DrumrollError, match="not fitted"):
        write_figures(idatas, "bouncing-ball", tmp_path)
    with pytest.raises(DrumrollError, match="no such directory"):
        write_figures(idatas, "pendulum", tmp_path / "missing")


def test_one_model_with_given_comparison_and_bayes_factors(idatas, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loos = {m: az.loo(d, pointwise=True) for m, d in idatas.items()}
    rows = []
    for model, loo in loos.items():
        diff = np.asarray(loo.loo_i) - np.asarray(loos["pendulum"].loo_i)
        rows.append({"model": model, "elpd_loo": float(loo.elpd_loo),
                     "elpd_loo_se": float(loo.se), "elpd_loo_diff": float(diff.sum()),
                     "elpd_loo_diff_se": float(np.sqrt(diff.size * diff.var())),
                     "log_bayes_factor": 0.0 if model == "pendulum" else -12.3,
                     "log_bayes_factor_err": 0.2})
    path = plot_comparison(rows, "pendulum", tmp_path / "comparison.png")
    width, _ = png_size(path)
    assert width > 900  # two panels
    single = {"powerlaw": idatas["powerlaw"]}
    written = write_figures(single, "powerlaw", tmp_path / ".", None, overwrite=True)
    assert set(written) == set(FIGURE_FILES)


def test_loo_comparison_is_model_minus_main(idatas):
    rows = {r["model"]: r for r in loo_comparison(idatas, "pendulum")}
    assert rows["pendulum"]["elpd_loo_diff"] == pytest.approx(0.0)
    assert rows["pendulum"]["elpd_loo_diff_se"] == pytest.approx(0.0)
    diff = rows["small-angle"]["elpd_loo"] - rows["pendulum"]["elpd_loo"]
    assert rows["small-angle"]["elpd_loo_diff"] == pytest.approx(diff)
    assert rows["small-angle"]["elpd_loo_diff_se"] > 0


def test_observed_flight_errors_combine_jitter_and_onset_sigmas(idatas, observed):
    times, sigmas = observed
    t, err = observed_flights(idatas["pendulum"])
    np.testing.assert_allclose(t, np.diff(times))
    jitter = float(np.median(idatas["pendulum"].posterior["jitter_ms"])) * 1e-3
    var = jitter**2 + sigmas**2
    np.testing.assert_allclose(err, np.sqrt(var[:-1] + var[1:]))


def test_residuals_are_relative_to_the_median_prediction(idatas, observed):
    r = onset_residuals(idatas["pendulum"])
    replicated = idatas["pendulum"].posterior_predictive["onset_time"].values.reshape(
        -1, N_ONSETS)
    np.testing.assert_allclose(r["residual"], observed[0] - np.median(replicated, axis=0))
    assert np.all(r["pp_lo"] < 0) and np.all(r["pp_hi"] > 0)
    assert np.all(r["model_hi"] - r["model_lo"] < r["pp_hi"] - r["pp_lo"])


def test_lag_one_correlation_tells_pattern_from_noise():
    rng = np.random.default_rng(5)
    assert abs(lag_one_correlation(rng.standard_normal(400))) < 0.15
    assert lag_one_correlation(np.sin(np.linspace(0, 3, 40))) > 0.8
    assert np.isnan(lag_one_correlation(np.zeros(3)))


def test_sampled_parameters_skip_derived_and_fixed(idatas):
    assert plot_style.sampled_parameters(idatas["pendulum"]) == [
        "alpha", "pivot_mm", "height_mm", "jitter_ms"]
    # without the sampler's list: everything that is not derived and varies
    assert plot_style.sampled_parameters(idatas["small-angle"]) == [
        "alpha", "jitter_ms", "pivot_mm", "height_mm"]
    assert corner_parameters(idatas["pendulum"])[-1] == "t_b"
    assert plot_style.parameter_label("pivot_mm") == "$d$ (mm)"
    assert plot_style.parameter_label("stick_length_mm") == "$l_1$ (mm)"
    assert plot_style.parameter_label("t_c") == "$t_C$ (s)"


def test_corner_title_rounds_to_the_error_and_far_truths_are_flagged(idatas):
    values = np.random.default_rng(0).normal(131.24, 1.3, 4000)
    title = quantile_title("pivot_mm", values)
    assert title.startswith("$d$ = $131.") and title.endswith(" mm")
    fig = draw_corner(idatas["powerlaw"], truths={"alpha": 0.5, "t_b": 0.2502})
    titles = " ".join(ax.get_title() for ax in fig.axes)
    assert "off scale" in titles  # alpha = 0.5 is hundreds of sigma away
    fig.clear()


def test_figures_leave_no_pyplot_state(written):
    import matplotlib.pyplot as plt

    assert plt.get_fignums() == []
    assert os.environ.get("MPLBACKEND", "agg").lower() in {"agg", "module://matplotlib_inline"
                                                            ".backend_inline"}
