"""Bounce numbers from the onset table to the fit: a gap is a missing onset, not a longer flight.

The likelihood is checked against an independent reference (numpy and scipy on the kept
onsets alone, T0 integrated by quadrature), every likelihood path against the others on
gapped data, and ``estimate`` end to end: a roll with one onset removed (its bounce column
keeping the gap) is fitted like the whole roll, while the same onsets numbered 0 … N − 1 are
not.
"""

from __future__ import annotations

import json
import math
import zlib
from pathlib import Path

import numpy as np
import pytest
from scipy import special, stats

from configs import BALL_CONFIG
from drumroll.cli.estimate import terminal_table
from drumroll.cli.main import main
from drumroll.inference.coordinates import SamplerCoordinates
from drumroll.inference.likelihood import (
    T0_WINDOW_S,
    OnsetData,
    gaussian_marginal,
    gaussian_marginal_lean,
    pointwise_log_likelihood,
    student_t_one,
)
from drumroll.inference.loo import conditional_pointwise
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.results import Onset, Summary
from drumroll.onsets import OnsetTable
from drumroll.pipeline import choose_roll, estimate
from drumroll.reporting.markdown import render_blocks
from drumroll.reporting.outputs import load_posteriors
from drumroll.reporting.report import onsets_section, render_report
from tests.unit.inference.test_posterior import _config, _points

#: The simulated ball: α, t_B (s), timing jitter (s), onsets, the bounce left out.
ALPHA, T_B, JITTER, N_ONSETS, GAP = 0.85, 0.40, 2e-4, 20, 8



def ball_times(n: int = N_ONSETS, seed: int = 0, start: float = 0.3) -> np.ndarray:
    """Onset times of an exact power-law roll (T_k = t_B α^k) with Gaussian jitter."""
    impacts = np.concatenate(([0.0], np.cumsum(T_B * ALPHA ** np.arange(1, n))))
    return start + impacts + np.random.default_rng(seed).normal(0.0, JITTER, n)


def table(times: np.ndarray, **numbers) -> OnsetTable:
    nan = np.full(times.size, np.nan)
    return OnsetTable(times, nan, nan, np.zeros(times.size), **numbers)


# -- the likelihood ----------------------------------------------------------------------------
def gapped_case(seed: int = 4):
    """Impacts τ_0 … τ_K of two parameter rows, onsets at bounces with 2 and 5 missing."""
    rng = np.random.default_rng(seed)
    impacts = np.concatenate((np.zeros((2, 1)), np.cumsum(0.3 * 0.8 ** np.arange(1, 9)
                                                           * rng.uniform(0.98, 1.02, (2, 8)),
                                                           axis=1)), axis=1)
    bounces = np.array([0, 1, 3, 4, 6, 7, 8])
    times = 1.1 + impacts[0, bounces] + rng.normal(0.0, 1e-3, bounces.size)
    sigmas = rng.uniform(0.0, 5e-4, bounces.size)
    return impacts, bounces, times, sigmas


def reference_marginal(times, sigmas, impacts_at_onsets, jitter) -> float:
    """log ∫ Π_i N(t_i; T0 + τ_i, σ² + s_i²) dT0 / W by quadrature: numpy and scipy on the
    kept onsets alone, with their own model times, nothing shared with the code under test."""
    scale = np.sqrt(jitter**2 + sigmas**2)
    centre = np.mean(times - impacts_at_onsets)
    t0 = centre + np.linspace(-0.05, 0.05, 400_001)
    log_terms = stats.norm.logpdf(times[:, None], t0[None, :] + impacts_at_onsets[:, None],
                                  scale[:, None]).sum(axis=0)
    return float(special.logsumexp(log_terms) + math.log(t0[1] - t0[0])
                 - math.log(T0_WINDOW_S))


def test_gapped_likelihood_equals_the_full_one_by_hand_on_the_kept_onsets():
    impacts, bounces, times, sigmas = gapped_case()
    jitter = np.array([1e-3, 2e-3])
    data = OnsetData.from_arrays(times, sigmas, bounces)
    assert data.n_onsets == 7 and data.n_flights == 8 and data.missing == [2, 5]
    got = gaussian_marginal(data, impacts, jitter)[0]
    for row in range(2):
        want = reference_marginal(times, sigmas, impacts[row, bounces], jitter[row])
        assert got[row] == pytest.approx(want, abs=1e-6)
    # the other Gaussian paths: lean batch, lean one point
    np.testing.assert_allclose(gaussian_marginal_lean(data, impacts, jitter), got, rtol=1e-12)
    assert gaussian_marginal_lean(data, impacts[1], 2e-3) == pytest.approx(got[1], rel=1e-12)
    # equal extractor sigmas take the lean path's other branch
    equal = OnsetData.from_arrays(times, np.full(7, 3e-4), bounces)
    want = reference_marginal(times, np.full(7, 3e-4), impacts[0, bounces], 1e-3)
    assert gaussian_marginal_lean(equal, impacts, jitter)[0] == pytest.approx(want, abs=1e-6)
    # closing the gap up (numbering the onsets 0 … 6) is a different, worse fit
    closed = OnsetData.from_arrays(times, sigmas)
    assert gaussian_marginal(closed, impacts[:, :7], jitter)[0][0] < got[0] - 100


def test_student_t_and_pointwise_terms_use_each_onsets_own_bounce():
    impacts, bounces, times, sigmas = gapped_case()
    data = OnsetData.from_arrays(times, sigmas, bounces)
    jitter, t0, nu = np.array([1e-3, 2e-3]), np.array([1.1002, 1.0995]), np.array([4.0, 9.0])
    got = pointwise_log_likelihood(data, impacts, jitter, t0, "student-t", nu)
    scale = np.sqrt(jitter[:, None] ** 2 + sigmas**2)
    want = stats.t.logpdf(times - t0[:, None] - impacts[:, bounces], nu[:, None], scale=scale)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    one = student_t_one(data, impacts[0], 1e-3, 1.1002, 4.0)
    assert one == pytest.approx(want[0].sum(), rel=1e-12)
    gauss = pointwise_log_likelihood(data, impacts, jitter, t0)
    np.testing.assert_allclose(gauss, stats.norm.logpdf(times - t0[:, None]
                                                        - impacts[:, bounces], scale=scale))


def test_loo_terms_with_a_gap_are_ratios_of_marginals():
    impacts, bounces, times, sigmas = gapped_case()
    jitter = np.array([1e-3, 2e-3])
    data = OnsetData.from_arrays(times, sigmas, bounces)
    pointwise = conditional_pointwise(data, impacts, jitter)
    full = gaussian_marginal(data, impacts, jitter)[0]
    for i in range(bounces.size):
        keep = np.arange(bounces.size) != i
        part = OnsetData.from_arrays(times[keep], sigmas[keep], bounces[keep])
        # leaving out the first onset renumbers the rest from it: shift the model alike
        shift = impacts[:, bounces[keep][0]:] - impacts[:, [bounces[keep][0]]]
        np.testing.assert_allclose(pointwise[:, i],
                                   full - gaussian_marginal(part, shift, jitter)[0], atol=1e-9)


def test_bounce_numbers_are_counted_from_the_first_onset():
    data = OnsetData.from_arrays([1.0, 1.4, 1.7], None, [3, 4, 6])
    np.testing.assert_array_equal(data.bounces, [0, 1, 3])
    assert data.n_flights == 3 and data.missing == [2]
    for bad in ([0, 2, 2], [0, 1.5, 2]):
        with pytest.raises(ValueError):
            OnsetData.from_arrays([1.0, 1.4, 1.7], None, bad)
    plain = OnsetData.from_arrays([1.0, 1.4, 1.7])
    impacts = np.zeros((1, 3))
    assert plain.at_onsets(impacts) is impacts  # no gap: no copy on the samplers' path


@pytest.mark.parametrize("noise", ["gaussian", "student-t"])
@pytest.mark.parametrize("model", ["pendulum", "small-angle", "powerlaw"])
def test_every_likelihood_path_agrees_on_gapped_onsets(model, noise):
    """Lean batch, one-point (dynesty) and general (full forward model) paths, the sampler's
    T0 coordinate and the by-hand likelihood of the kept onsets all agree with a gap."""
    from drumroll.physics import StickGeometry, bounce_sequence

    stick = StickGeometry("cylinder-cone", 0.348, 0.06, 0.0075)
    b = bounce_sequence("pendulum", alpha=0.88, pivot=0.131, height=0.08, stick=stick,
                        n_flights=25)
    rng = np.random.default_rng(0)
    keep = np.setdiff1d(np.arange(26), [3, 11, 12, 25])
    times = 1.234 + b.impacts[0, keep] + rng.normal(0, 1e-4, keep.size)
    data = OnsetData.from_arrays(times, rng.uniform(0, 3e-4, keep.size), keep)
    assert data.n_flights == 24  # the last bounce heard is 24
    lp = LogPosterior.build(_config("table1"), model, data, noise)
    x = _points(lp, np.random.default_rng(zlib.crc32(f"{model}/{noise}".encode())))
    want = lp.reference(x)
    finite = np.isfinite(want)
    assert finite.sum() > 150
    np.testing.assert_allclose(lp(x)[finite], want[finite], rtol=1e-11, atol=1e-9)
    like = lp.log_likelihood_reference(x[finite][:40])
    one = [lp.log_likelihood_one(row) for row in x[finite][:40]]
    np.testing.assert_allclose(one, like, rtol=1e-11, atol=1e-9)
    # by hand on the kept onsets, at the three points nearest the data
    v = lp.space.values(x[finite][np.argsort(want[finite])[-3:]])
    # each impact m comes m contact times (sampled by default, the constant law) late
    impacts = lp.space.bounces_from_values(v, 24).impacts[:, keep] \
        + np.reshape(v["contact"], (-1, 1)) * keep
    scale = np.sqrt(np.reshape(v["jitter"], (-1, 1)) ** 2 + data.sigmas**2)
    like = lp.log_likelihood_reference(x[finite][np.argsort(want[finite])[-3:]])
    for row in range(3):
        if noise == "gaussian":
            hand = reference_marginal(times, data.sigmas, impacts[row], float(v["jitter"][row]))
            assert like[row] == pytest.approx(hand, abs=1e-6 * max(1.0, abs(hand)))
        else:
            nu = float(np.broadcast_to(v["nu"], (3,))[row])
            hand = stats.t.logpdf(times - v["t0"][row] - impacts[row], nu,
                                  scale=scale[row]).sum()
            assert like[row] == pytest.approx(hand, rel=1e-10)
    if noise == "student-t":  # the non-centred T0 coordinate centres on the kept onsets
        coords = SamplerCoordinates(lp.space, data)
        z = coords.to_sampler(x[finite][:20])
        np.testing.assert_allclose(coords.to_parameters(z)[0], x[finite][:20], rtol=1e-9)
        for row in range(5):  # nested sampling's one-point map, impacts included
            point, _, impacts_one = coords.to_parameters_one(z[row])
            np.testing.assert_allclose(point, x[finite][row], rtol=1e-9)
            assert lp.log_likelihood_one(point, impacts_one) == pytest.approx(
                lp.log_likelihood_reference(point[None])[0], rel=1e-10)


# -- estimate end to end -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def fits(tmp_path_factory):
    """The same simulated roll fitted whole, with bounce GAP left out (the bounce column
    keeps the gap: through the command line, every output written), and with the gap closed
    up (an old-style CSV without the numbers, so the onsets are numbered 0 … N − 2)."""
    folder = tmp_path_factory.mktemp("gaps")
    config = folder / "ball.toml"
    # ball_times has no contact time: the fit is told so (at the prior's edge, a sampled
    # τ_c's posterior sits above zero and pulls α down with it)
    config.write_text(BALL_CONFIG.replace("[priors]\n", "[priors]\ncontact_ms = 0\n"))
    times = ball_times()
    bounces = np.arange(N_ONSETS)
    kept = bounces != GAP
    (folder / "full.csv").write_text(table(times).to_csv())
    (folder / "gap.csv").write_text(table(times[kept], bounce=bounces[kept]).to_csv())
    closed = "\n".join(",".join(line.split(",")[:5]) for line in
                       table(times[kept]).to_csv().splitlines())
    (folder / "closed.csv").write_text(closed + "\n")
    out = folder / "gap-out"
    return {"full": estimate(folder / "full.csv", config),
            "closed": estimate(folder / "closed.csv", config),
            "gap_status": main(["estimate", str(folder / "gap.csv"), "--prior", str(config),
                                "-o", str(out), "-q"]),
            "out": out}


def test_a_gap_is_fitted_like_the_whole_roll(fits):
    assert fits["gap_status"] == 0
    gap = json.loads((fits["out"] / "summary.json").read_text())
    full, closed = fits["full"].summary, fits["closed"].summary
    assert gap["n_onsets"] == N_ONSETS - 1 and full.n_onsets == N_ONSETS
    for name, truth in (("alpha", ALPHA), ("t_b", T_B)):
        a, b = full.parameters[name], gap["parameters"][name]
        assert abs(a.mean - b["mean"]) < 0.5 * max(a.sd, b["sd"]), name
        assert a.hdi_low < truth < a.hdi_high, name
        assert b["hdi_low"] < truth < b["hdi_high"], name
    # The same onsets without their bounce numbers take the gap for one long flight: the
    # fit is off by many of the gapped fit's sd, and needs a jitter of milliseconds.
    wrong = closed.parameters
    assert abs(wrong["alpha"].mean - ALPHA) > 10 * gap["parameters"]["alpha"]["sd"]
    assert abs(wrong["t_b"].mean - T_B) > 10 * gap["parameters"]["t_b"]["sd"]
    assert wrong["jitter_ms"].mean > 10 * JITTER * 1e3
    assert gap["parameters"]["jitter_ms"]["mean"] < 2 * JITTER * 1e3


def test_summary_report_and_posterior_name_the_missing_bounce(fits):
    out = fits["out"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["missing_bounces"] == [GAP]
    assert summary["roll"] == 0 and summary["n_rolls"] == 1
    note = f"bounce {GAP} missing (inaudible or masked): fitted as gap"
    assert summary["notes"] == [note]
    assert [o["bounce"] for o in summary["onsets"]] == [k for k in range(N_ONSETS) if k != GAP]
    report = (out / "report.md").read_text()
    assert f"> **Note:** {note}." in report
    assert f"| {GAP + 1} | " in report and "(after a gap)" in report
    assert f"| {GAP} | " not in report.split("Onset times")[1]
    idata = load_posteriors(out / "posterior.nc")["powerlaw"]
    np.testing.assert_array_equal(idata.observed_data["onset"].values,
                                  [k for k in range(N_ONSETS) if k != GAP])
    np.testing.assert_array_equal(idata.posterior_predictive["flight"].values,
                                  np.arange(1, N_ONSETS))
    assert idata.posterior_predictive["onset_time"].shape[-1] == N_ONSETS - 1
    for name in ("bounce_series.png", "residuals.png"):
        assert (out / name).stat().st_size > 10_000


def test_figures_leave_out_the_flights_next_to_a_gap(fits):
    from drumroll.inference.summary import observed_flights, onset_residuals

    idata = load_posteriors(fits["out"] / "posterior.nc")["powerlaw"]
    observed = observed_flights(idata)
    flights = np.array(observed.time_s, dtype=float)
    errors = np.array(observed.err_s, dtype=float)
    assert flights.size == N_ONSETS - 1
    missing = [GAP - 1, GAP]  # flights GAP and GAP + 1 (entries k − 1)
    assert np.isnan(flights[missing]).all() and np.isnan(errors[missing]).all()
    times = ball_times()
    others = np.setdiff1d(np.arange(N_ONSETS - 1), missing)
    np.testing.assert_allclose(flights[others], np.diff(times)[others], atol=2e-8)  # CSV digits
    r = onset_residuals(idata)
    np.testing.assert_array_equal(r.bounce, idata.observed_data["onset"].values)
    low, high = np.array(r.low), np.array(r.high)
    model_low, model_high = np.array(r.model_low), np.array(r.model_high)
    assert np.all(model_low < model_high)
    # the noise-free model at each onset's own bounce lies inside the predictive band
    assert np.all(low < model_low) and np.all(model_high < high)


def test_a_roll_numbered_from_a_later_bounce_keeps_its_numbering(tmp_path):
    times = ball_times(8)
    fitted = choose_roll(table(times, bounce=np.arange(3, 11)))
    np.testing.assert_array_equal(fitted.onsets.bounce, np.arange(8))
    np.testing.assert_array_equal(fitted.data.bounces, np.arange(8))
    assert fitted.numbered_from == 3  # the models are fitted from impact 3
    assert fitted.notes == ["the roll's first onset is numbered bounce 3 in the onsets, which "
                            "counts the first 3 impacts of the roll as not heard: the fit "
                            "starts from that numbering"]
    assert choose_roll(table(times, bounce=np.arange(8))).numbered_from == 0


@pytest.mark.parametrize("noise", ["gaussian", "student-t"])
def test_a_ball_numbered_from_its_sixth_impact_is_fitted_on_the_truth(tmp_path, noise):
    """A ball's roll (t_B = 0.4 s, α = 0.85) whose first five impacts went unheard, in a file
    numbered from bounce 5: every model is fitted with that numbering, α and t_B (the first
    rebound's, extrapolated over the five missed flights, 1.26 s) and T0 (impact 0's time)
    come out on the truth, with either noise (under Student-t T0 is sampled in a window that
    the missed flights place: the second before the first onset did not hold it)."""
    times = ball_times()
    (tmp_path / "ball.toml").write_text(BALL_CONFIG + f'\n[likelihood]\nnoise = "{noise}"\n')
    result = estimate(table(times[5:], bounce=np.arange(5, N_ONSETS)), tmp_path / "ball.toml",
                      progress=False)
    assert result.summary.onsets[0].bounce == 5
    stats = result.summary.parameters
    truths = {"alpha": ALPHA, "t_b": T_B, **({"t0_s": times[0]} if noise == "student-t" else {})}
    for name, truth in truths.items():
        assert abs(stats[name].mean - truth) < 4 * stats[name].sd, name


# -- several rolls ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def two_roll_csv(tmp_path_factory):
    """Roll 0: 6 onsets (bounce 3 not heard); roll 1, 3 s later: 12 onsets."""
    folder = tmp_path_factory.mktemp("rolls")
    first, second = ball_times(7, seed=1), ball_times(12, seed=2, start=4.0)
    keep = np.arange(7) != 3
    times = np.concatenate((first[keep], second))
    bounces = np.concatenate((np.arange(7)[keep], np.arange(12)))
    rolls = np.repeat([0, 1], [6, 12])
    path = folder / "two.csv"
    path.write_text(table(times, bounce=bounces, roll=rolls).to_csv())
    (folder / "ball.toml").write_text(BALL_CONFIG)
    return path, folder / "ball.toml"


def test_the_longest_roll_is_fitted_and_the_others_are_named(two_roll_csv, tmp_path, capsys):
    path, config = two_roll_csv
    assert main(["estimate", str(path), "--prior", str(config), "-o", str(tmp_path / "o"),
                 "-q"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == ("note: the recording holds 2 rolls (onsets 6, 12); fitting roll 1, the "
                      "longest; choose another with --roll N")
    assert out[1] == "powerlaw: 12 onsets"
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["roll"] == 1 and summary["n_rolls"] == 2 and summary["n_onsets"] == 12
    assert summary["missing_bounces"] == []
    assert summary["onsets"][0]["time_s"] > 4.0
    assert abs(summary["parameters"]["alpha"]["mean"] - ALPHA) < 0.01
    assert "(roll 1 of 2)" in (tmp_path / "o" / "report.md").read_text()


def test_roll_chosen_by_number_in_the_api(two_roll_csv):
    path, config = two_roll_csv
    result = estimate(path, config, roll=0)
    summary = result.summary
    assert summary.roll == 0 and summary.n_onsets == 6
    assert summary.missing_bounces == (3,)
    assert summary.notes == (
        "the recording holds 2 rolls (onsets 6, 12); fitting roll 0, as asked",
        "bounce 3 missing (inaudible or masked): fitted as gap")
    assert result.onsets.rolls == (0,) and len(result.onsets) == 6
    lines = terminal_table(result).splitlines()  # the notes come before the numbers
    assert lines[:3] == [f"note: {note}" for note in summary.notes] + ["powerlaw: 6 onsets"]


def test_a_roll_beyond_those_present_is_one_line_before_sampling(two_roll_csv, tmp_path,
                                                                capsys, monkeypatch):
    import drumroll.pipeline as pipeline

    path, config = two_roll_csv
    monkeypatch.setattr(pipeline, "_fit", lambda *a, **k: pytest.fail("sampling started"))
    assert main(["estimate", str(path), "--prior", str(config), "-o", str(tmp_path / "o"),
                 "--roll", "2", "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"drumroll: error: {path}: no roll 2; the recording holds rolls 0, 1 "
                   "(--roll counts from 0)")
    assert not (tmp_path / "o").exists()
    with pytest.raises(SystemExit) as caught:
        main(["estimate", str(path), "--prior", str(config), "--roll", "-1"])
    assert caught.value.code == 2


def test_runs_files_take_a_roll_per_run(tmp_path, capsys):
    from drumroll.table import load_runs
    from drumroll.table.execute import run_key
    from tests.unit.table.test_table import BASE, RUN_H80, runs_text, write_onsets

    (tmp_path / "base.toml").write_text(BASE)
    write_onsets(tmp_path / "h80.txt", "table2_h80")
    (tmp_path / "runs.toml").write_text(runs_text(RUN_H80 + "roll = 0\n"))
    run = load_runs(tmp_path / "runs.toml").runs[0]
    assert run.roll == 0
    (tmp_path / "runs.toml").write_text(runs_text(RUN_H80))
    other = load_runs(tmp_path / "runs.toml").runs[0]
    assert other.roll is None and run_key(other) != run_key(run)
    for value, message in (("-1", "roll: must not be negative"),
                           ("1.5", "roll: expected a whole number")):
        (tmp_path / "runs.toml").write_text(runs_text(RUN_H80 + f"roll = {value}\n"))
        assert main(["table", str(tmp_path / "runs.toml"), "-q"]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and f"run 'h80'.{message}" in err


# -- the report on its own -----------------------------------------------------------------------
def test_report_notes_and_onset_table_from_a_summary():
    onsets = (Onset(1.0, 0.0, 0), Onset(1.4, 0.0, 1), Onset(1.95, 0.0, 3))
    lines = render_blocks(onsets_section(onsets), Path("."))
    assert "| 1 | 1.400000 | 400.000 |" in lines
    assert "| 3 | 1.950000 | — (after a gap) |" in lines
    text = render_report(Summary(
        model="powerlaw", n_onsets=3, roll=2, n_rolls=3, onsets=onsets,
        notes=("bounce 2 missing (inaudible or masked): fitted as gap",)))
    assert "3 onsets (roll 2 of 3)" in text
    assert "> **Note:** bounce 2 missing (inaudible or masked): fitted as gap." in text


def test_onset_figure_draws_each_roll_and_breaks_at_a_gap(two_roll_csv, tmp_path):
    import soundfile as sf

    from drumroll.onsets import read_onsets
    from drumroll.reporting.onset_plot import write_onset_plot

    path, _ = two_roll_csv
    rate = 8000
    audio = tmp_path / "roll.wav"
    sf.write(audio, 0.01 * np.random.default_rng(0).standard_normal(8 * rate), rate)
    figure = write_onset_plot(tmp_path / "onsets.png", audio, read_onsets(path))
    assert figure.stat().st_size > 10_000


def test_a_tables_notes_carry_each_runs_notes(tmp_path):
    from drumroll.table import format_table, load_runs
    from drumroll.table.execute import TableResult
    from tests.unit.table.test_table import BASE, RUN_H80, fake_row, runs_text, write_onsets

    (tmp_path / "base.toml").write_text(BASE)
    write_onsets(tmp_path / "h80.txt", "table2_h80")
    (tmp_path / "runs.toml").write_text(runs_text(RUN_H80))
    note = "bounce 3 missing (inaudible or masked): fitted as gap"
    row = fake_row(0.9, 0.25, notes=(note,))
    result = TableResult(runs=load_runs(tmp_path / "runs.toml"), rows=[row])
    assert f"Note (h80): {note}." in format_table(result, "markdown")
    assert json.loads(format_table(result, "json"))["rows"][0]["notes"] == [note]
