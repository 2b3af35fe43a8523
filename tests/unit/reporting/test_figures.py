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
from drumroll.inference.adequacy import adequacy
from drumroll.inference.comparison import compare_models
from drumroll.inference.results import ComparisonRow, Diagnostics, ModelSummary, Summary
from drumroll.inference.summary import (
    flight_series,
    observed_flights,
    onset_residuals,
    parameter_summary,
)
from drumroll.reporting import plot_style
from drumroll.reporting.comparison_plot import plot_comparison
from drumroll.reporting.corner_plot import corner_parameters, draw_corner, quantile_title
from drumroll.reporting.figures import FIGURES, FigureInputs, figure_files, write_figures
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
        posterior_predictive={"onset_time": replicated, "onset_time_model": mean,
                              "flight_time_model": flights},
        log_likelihood={"onset_time": log_lik},
        observed_data={"onset_time": observed},
        constant_data={"onset_sigma_s": sigmas},
        prior=prior,
        sample_stats={"lp": log_lik.sum(axis=-1)},
        coords={"onset": np.arange(N_ONSETS), "flight": np.arange(1, N_ONSETS)},
        dims={"onset_time": ["onset"], "onset_time_model": ["onset"],
              "flight_time_model": ["flight"], "onset_sigma_s": ["onset"]},
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


def summarise(idatas: dict[str, az.InferenceData], main: str) -> Summary:
    """The summary the pipeline would give these fits, made by the same functions."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rows, preferred, verdict, loos = compare_models(idatas, main)
    models = {m: ModelSummary(parameters=parameter_summary(d), flights=flight_series(d),
                              residuals=onset_residuals(d), adequacy=adequacy(d))
              for m, d in idatas.items()}
    return Summary(model=main, n_onsets=N_ONSETS, parameters=models[main].parameters,
                   models=models, observed_flights=observed_flights(idatas[main]),
                   comparison=rows, preferred=preferred, verdict=verdict,
                   diagnostics={m: Diagnostics() for m in idatas},
                   loo={m: loo.summary() for m, loo in loos.items()})


def inputs_of(idatas: dict[str, az.InferenceData], main: str,
              truths: dict[str, float] | None = None) -> FigureInputs:
    return FigureInputs(idatas=idatas, summary=summarise(idatas, main), truths=truths)


@pytest.fixture(scope="module")
def inputs(idatas) -> FigureInputs:
    return inputs_of(idatas, "pendulum",
                     truths={"alpha": 0.88, "pivot_mm": 131.0, "not_a_parameter": 1.0})


@pytest.fixture(scope="module")
def written(inputs, tmp_path_factory) -> dict[str, Path]:
    return write_figures(inputs, tmp_path_factory.mktemp("figures"))


def png_size(path: Path) -> tuple[int, int]:
    """Width and height from a PNG header (fails if the file is not a PNG)."""
    data = path.read_bytes()[:24]
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path.name} is not a PNG"
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_every_figure_is_written_as_a_sensible_png(written, inputs):
    files = figure_files(inputs)
    assert set(written) == set(files) == set(FIGURES) - {"onsets"}  # no audio here
    for key, path in written.items():
        assert path.name == FIGURES[key].file
        assert path.stat().st_size > 10_000, f"{path.name} is suspiciously small"
        width, height = png_size(path)
        assert 500 <= width <= 3000 and 300 <= height <= 3000, (path.name, width, height)
    # no temporary files left behind
    assert sorted(p.name for p in next(iter(written.values())).parent.iterdir()) == \
        sorted(files.values())


def test_existing_figures_are_not_overwritten(inputs, written):
    out = next(iter(written.values())).parent
    before = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in out.iterdir()}
    with pytest.raises(DrumrollError, match="already exists"):
        write_figures(inputs, out)
    after = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in out.iterdir()}
    assert before == after


def test_single_plot_refuses_then_overwrites_when_asked(idatas, tmp_path):
    path = tmp_path / "trace.png"
    path.write_bytes(b"old")
    stats = parameter_summary(idatas["powerlaw"])
    with pytest.raises(DrumrollError):
        plot_trace(idatas["powerlaw"], stats, path)
    assert path.read_bytes() == b"old"
    plot_trace(idatas["powerlaw"], stats, path, overwrite=True)
    png_size(path)


def test_unknown_main_model_and_missing_folder_are_user_errors(idatas, inputs, tmp_path):
    other = FigureInputs(idatas={"pendulum": idatas["pendulum"]},
                         summary=Summary(model="bouncing-ball"))
    with pytest.raises(DrumrollError, match="not fitted"):
        write_figures(other, tmp_path)
    with pytest.raises(DrumrollError, match="no such directory"):
        write_figures(inputs, tmp_path / "missing")


def test_comparison_with_bayes_factors_and_a_single_model(idatas, inputs, tmp_path):
    summary = inputs.summary
    rows = tuple(ComparisonRow(**{**r.to_json(), "pareto_k_bad": (),
                                  "log_bayes_factor": 12.3, "log_bayes_factor_err": 0.2})
                 for r in summary.comparison)
    path = plot_comparison(rows, summary.loo, "pendulum", tmp_path / "comparison.png")
    width, _ = png_size(path)
    assert width > 900  # two panels
    single = inputs_of({"powerlaw": idatas["powerlaw"]}, "powerlaw")
    written = write_figures(single, tmp_path / ".", overwrite=True)
    assert "comparison" not in written  # nothing to compare with
    assert set(written) == set(FIGURES) - {"onsets", "comparison"}


def test_comparison_rows_are_main_minus_model(inputs):
    summary = inputs.summary
    rows = {r.model: r for r in summary.comparison}
    diff = summary.loo["pendulum"].elpd_loo - summary.loo["small-angle"].elpd_loo
    assert rows["small-angle"].elpd_loo_diff == pytest.approx(diff)
    assert rows["small-angle"].elpd_loo_diff_se > 0


def test_observed_flight_errors_combine_jitter_and_onset_sigmas(idatas, observed):
    times, sigmas = observed
    flights = observed_flights(idatas["pendulum"])
    np.testing.assert_allclose(flights.time_s, np.diff(times))
    jitter = float(np.median(idatas["pendulum"].posterior["jitter_ms"])) * 1e-3
    var = jitter**2 + sigmas**2
    np.testing.assert_allclose(flights.err_s, np.sqrt(var[:-1] + var[1:]))


def test_residuals_are_relative_to_the_median_prediction(idatas, observed):
    r = onset_residuals(idatas["pendulum"])
    replicated = idatas["pendulum"].posterior_predictive["onset_time"].values.reshape(
        -1, N_ONSETS)
    np.testing.assert_allclose(r.residual, observed[0] - np.median(replicated, axis=0))
    low, high = np.array(r.low), np.array(r.high)
    assert np.all(low < 0) and np.all(high > 0)
    np.testing.assert_allclose(low + np.median(replicated, axis=0),
                               np.quantile(replicated, 0.05, axis=0))
    assert np.all(np.array(r.model_high) - np.array(r.model_low) < high - low)


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


@pytest.mark.parametrize("key", ["trace", "corner"])
def test_one_draw_png_is_savefig_s_file(idatas, inputs, tmp_path, key):
    """plot_style.write_png draws once what savefig draws twice (layout, then render) for a
    figure with a layout engine: the file is the same, byte for byte."""
    from drumroll.reporting.corner_plot import draw_corner
    from drumroll.reporting.trace_plot import draw_trace

    def draw():
        with plot_style.style():
            if key == "corner":
                return draw_corner(idatas["pendulum"])
            return draw_trace(idatas["pendulum"], inputs.summary.parameters)

    ours, theirs = tmp_path / "ours.png", tmp_path / "theirs.png"
    with plot_style.style():
        plot_style.write_png(draw(), ours, dpi=plot_style.DPI, facecolor="white",
                             pil_kwargs={"compress_level": 1})
        draw().savefig(theirs, dpi=plot_style.DPI, format="png", facecolor="white",
                       pil_kwargs={"compress_level": 1})
    assert ours.read_bytes() == theirs.read_bytes()


def test_a_bounce_after_a_gap_keeps_its_band():
    """The residuals' band breaks at missing bounces; an onset with neither neighbour (the
    last one after two missed bounces, as table2_h80's) still gets its band, as a box."""
    from matplotlib.figure import Figure

    from drumroll.reporting.residuals import fill_band

    ax = Figure().subplots()
    bounces = np.array([0, 1, 2, 5])
    fill_band(ax, bounces, np.array([-1.0, -1.0, -1.0, -2.0]), np.array([1.0, 1.0, 1.0, 3.0]))
    boxes = [c.get_paths()[0].get_extents() for c in ax.collections]
    covering_5 = [b for b in boxes if b.x0 <= 5.0 <= b.x1]
    assert len(covering_5) == 1
    box = covering_5[0]
    assert (box.x0, box.x1, box.y0, box.y1) == pytest.approx((4.75, 5.25, -2.0, 3.0))
    # the run 0-2 is one band, as before
    assert any(b.x0 == pytest.approx(0.0) and b.x1 == pytest.approx(2.0) for b in boxes)


def test_trace_texts_stay_inside_and_apart_with_awkward_numbers(observed):
    """The trace's layout keeps every text inside the figure and off the other rows, and
    each row's y label off its tick labels, where the numbers are awkward: a T0 an hour into
    a recording (ticks of nine characters), an α within 1e-5 of 1, a jitter that needs an
    offset (×1e−4), and every title flagged for its R-hat. (Margins fixed in inches failed
    this: the T0 label left the figure and the offset text pushed a title into the row
    above.)"""
    from types import SimpleNamespace

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    from drumroll.reporting.trace_plot import draw_trace

    times, sigmas = observed
    idata = make_idata("pendulum", times, sigmas, 5, n_chain=8, n_draw=30)
    rng = np.random.default_rng(6)
    post = idata.posterior
    post["t0_s"] = 0.0 * post["t0_s"] + 3599.123456 + rng.normal(0.0, 3e-5, post["t0_s"].shape)
    post["alpha"] = 0.0 * post["alpha"] + 0.999991 + rng.normal(0.0, 2e-6, post["alpha"].shape)
    post["jitter_ms"] = post["jitter_ms"] * 1e-3
    flagged = {name: SimpleNamespace(r_hat=1.0123, ess_bulk=123456.0)
               for name in post.data_vars}
    with plot_style.style():
        fig = draw_trace(idata, flagged)
        fig.set_dpi(plot_style.DPI)
        renderer = FigureCanvasAgg(fig).get_renderer()
        fig.draw(renderer)
    inside = fig.bbox.padded(1.0)
    plots = [ax for ax in fig.axes if ax.get_subplotspec().colspan.start == 0]
    assert len(plots) >= 4
    for row, ax in enumerate(plots):
        ticks = [t.label1 for t in ax.yaxis.get_major_ticks()
                 if t.label1.get_visible() and t.label1.get_text()]
        texts = [*(c for c in ax.get_children() if isinstance(c, Text)), ax.yaxis.label,
                 ax.yaxis.offsetText, *ticks]
        for text in texts:
            if not text.get_text():
                continue
            box = text.get_window_extent(renderer)
            assert inside.contains(box.x0, box.y0) and inside.contains(box.x1, box.y1), \
                text.get_text()
            for other in plots[:row] + plots[row + 1:]:
                assert not box.overlaps(other.get_window_extent(renderer)), text.get_text()
        label = ax.yaxis.label.get_window_extent(renderer)
        assert not any(label.overlaps(t.get_window_extent(renderer)) for t in ticks)
