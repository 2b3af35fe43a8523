"""The screen of the renumbered rolls: the proposal's density against scipy's, and the
screen's estimates against the fitted evidences of the bundled roll."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from drumroll.config import load_config, parse_config
from drumroll.inference.evidence import Evidence
from drumroll.inference.inference_data import parameter_draws
from drumroll.inference.laplace import LaplaceEstimate
from drumroll.inference.likelihood import OnsetData
from drumroll.inference.missed_impacts import (
    PROPOSAL_NU,
    SCREEN_NATS,
    STRAY,
    Branch,
    ImportanceSample,
    Numberings,
    Screen,
    _mixture_draws,
    importance_sample,
    missed_note,
    missed_warning,
    mixed_numberings,
    needs_fit,
    renumbering,
    screen,
    shifted,
    stray_log_density,
    stray_warning,
)
from drumroll.inference.posterior import LogPosterior, t0_window
from drumroll.inference.settings import estimate_settings
from drumroll.pipeline import _fit, _sampled_draws, choose_roll, load_onsets
from paths import CORPUS, DATA

COVARIANCE = np.array([[2.0, 0.6, -0.3], [0.6, 1.0, 0.2], [-0.3, 0.2, 0.5]])

def test_a_numbering_is_fitted_unless_screened_far_below():
    assert needs_fit(50.0, 60.0) and needs_fit(math.nan, 60.0) and needs_fit(40.0, math.nan)
    assert not needs_fit(60.0 - SCREEN_NATS - 0.1, 60.0)
    note = missed_note("pendulum", (0.99, 0.01, 1e-12), screened={2})
    assert "P(1) = 0.01" in note and "P(2) < 3e-07 (screened)" in note


def test_another_numbering_is_fitted_only_where_the_first_is_not_clearly_preferred():
    assert renumbering((0.96, 0.04, 0.0)) is None
    assert renumbering((0.5, 0.2, 0.3)) is None  # not clearly preferred, but the likeliest
    assert renumbering((0.3, 0.6, 0.1)) is None  # likelier, not clearly preferred: kept
    assert renumbering((0.03, 0.96, 0.01)) == 1
    assert renumbering((0.01, 0.0, 0.99)) == 2
    assert renumbering((0.0, 0.9, 0.1), numbered_from=1) is None
    assert renumbering(()) is None
    # the stray sound (STRAY, -1) among the numberings, by name
    assert renumbering({STRAY: 0.97, 0: 0.03, 1: 0.0}) == STRAY
    assert renumbering({STRAY: 0.02, 0: 0.98}) is None
    assert renumbering({STRAY: 0.4, 0: 0.2, 1: 0.4, 2: math.nan}) is None
    assert renumbering({STRAY: 0.01, 0: 0.0, 1: 0.99, 2: math.nan}) == 1


def test_the_stray_numbering_is_the_onsets_after_the_first_numbered_from_the_second():
    data = OnsetData.from_arrays([0.0, 0.3, 0.55, 0.77, 0.97], [1e-4] * 5, [0, 1, 2, 4, 5])
    rest = shifted(data, STRAY)
    assert rest.times.tolist() == [0.3, 0.55, 0.77, 0.97]
    assert rest.sigmas.tolist() == [1e-4] * 4
    assert rest.bounces.tolist() == [0, 1, 3, 4]
    assert shifted(data, 1).bounces.tolist() == [1, 2, 3, 5, 6]


def test_a_stray_sound_is_uniform_over_the_first_flights_the_tracker_joins():
    """The second flight T₁ = 0.25 s: the tracker takes a first flight T₀ with
    T₁ ≥ 0.25 T₀ and T₁ ≤ e^0.15 T₀, so T₀ lies in [0.2152, 1.0] s: 0.7848 s long."""
    data = OnsetData.from_arrays([0.0, 0.26, 0.51, 0.74], [1e-4] * 4)
    assert stray_log_density(data) == pytest.approx(-math.log(1.0 - 0.25 * math.exp(-0.15)))
    # a bounce unheard after the second onset: T₁ per bounce; a long flight: capped at 2 s
    gap = OnsetData.from_arrays([0.0, 0.9, 2.1, 2.6], [1e-4] * 4, [0, 1, 3, 4])
    assert stray_log_density(gap) == pytest.approx(-math.log(2.0 - 0.6 * math.exp(-0.15)))


def test_a_stray_sounds_level_is_weighed_with_the_trackers_level_model():
    """Δ, the first onset's level against the median of the next three: Student t (3 degrees
    of freedom, 6 dB) for the first impact, uniform over 60 dB for a stray sound (scipy's t
    as the reference)."""
    data = OnsetData.from_arrays([0.0, 0.26, 0.51, 0.74, 0.96], [1e-4] * 5)
    timing = stray_log_density(data)
    for delta_db in (-27.0, 0.0, 6.0):
        amplitude = np.array([10 ** (delta_db / 20), 1.2, 1.0, 0.8, 0.7])
        expected = -math.log(60.0) - (stats.t.logpdf(delta_db / 6.0, 3) - math.log(6.0))
        assert stray_log_density(data, amplitude) == pytest.approx(timing + expected)
    # 27 dB under: 16 times likelier a stray sound; as loud: 3.7 times likelier the impact
    assert math.exp(stray_log_density(data, np.array([10 ** (-27 / 20), 1, 1, 1, 1])) - timing
                    ) == pytest.approx(16.3, abs=0.1)
    # unknown levels (an onset file without amplitudes, levels of 0): the timing alone
    assert stray_log_density(data, np.full(5, np.nan)) == timing
    assert stray_log_density(data, np.zeros(5)) == timing


def test_an_undecided_stray_sound_is_warned_of_either_way():
    assert stray_warning("pendulum", 0.001, dropped=False) is None
    assert stray_warning("pendulum", 0.999, dropped=True) is None
    assert stray_warning("pendulum", None, dropped=False) is None
    kept = stray_warning("pendulum", 0.3, dropped=False)
    assert "may be a sound that is no impact" in kept and "P = 0.3" in kept
    dropped = stray_warning("pendulum", 0.8, dropped=True)
    assert "may be its first impact (P = 0.2)" in dropped


def _numberings(laplace_log_z: dict[int, float], sampled: dict[int, tuple[float, float]]
                ) -> Numberings:
    """Screens with these Laplace estimates, and importance-sampled evidences (ln Z, Pareto
    k: trusted where k ≤ 0.7) from some of them."""
    found = Numberings()
    for m, log_z in laplace_log_z.items():
        found.screens[m] = Screen(log_z)
        found.screen_evidences[m] = None
    for m, (log_z, k) in sampled.items():
        found.screen_evidences[m] = Evidence(log_z, 0.01, 8000, ess=4000.0,
                                             method="importance", pareto_k=k)
    return found


def test_the_screens_renumber_a_roll_only_on_evidence_they_trust():
    # table2_h80 with two impacts cut off (measured): numbered from impact 0 its screen is
    # not trusted (k = 1.4) and 49 nats below the trusted screen of impact 2.
    late = _numberings({0: 14.4, 1: 55.8, 2: 63.7}, {0: (24.5, 1.37), 1: (55.9, 0.31),
                                                      2: (63.7, 0.14)})
    assert late.early_renumbering(0) == 2
    assert late.log_z == {1: 55.9, 2: 63.7}  # the trusted ones, kept for the next pass
    # The whole roll: impact 0 is the likeliest.
    whole = _numberings({0: 76.8, 1: 70.6, 2: 20.7}, {0: (77.0, 0.15), 1: (70.4, 0.0)})
    assert whole.early_renumbering(0) is None and whole.log_z == {}
    # Another numbering likelier, but by an estimate its own diagnostic does not trust.
    assert _numberings({0: 50.0, 1: 70.0}, {0: (50.0, 0.2), 1: (70.0, 0.9)}
                       ).early_renumbering(0) is None
    # The first numbering's screen untrusted and within SCREEN_NATS of the likeliest: the
    # fits decide.
    assert _numberings({0: 60.0 - SCREEN_NATS + 1.0, 1: 60.0}, {1: (60.0, 0.2)}
                       ).early_renumbering(0) is None
    # Both trusted: the other likelier (P(1) = e/(1 + e) = 0.73) but not clearly preferred:
    # the first numbering is kept; 4 nats ahead (P(1) = 0.98), it is not.
    assert _numberings({0: 50.0, 1: 51.0}, {0: (50.0, 0.2), 1: (51.0, 0.2)}
                       ).early_renumbering(0) is None
    assert _numberings({0: 50.0, 1: 54.0}, {0: (50.0, 0.2), 1: (54.0, 0.2)}
                       ).early_renumbering(0) == 1
    # A screen with no estimate at all: nothing is decided.
    assert _numberings({0: math.nan, 1: 60.0}, {1: (60.0, 0.2)}).early_renumbering(0) is None


def test_the_proposal_density_is_scipys_mixture():
    """Two branches over three columns: a Student-t over all of them, and one over the first
    two with the third held absent (uniform on its plateau [−0.5, 0))."""
    rng = np.random.default_rng(2)
    present = Branch((), ("a", "b", "c"), LaplaceEstimate(0.0, np.zeros(3)), 0.0)
    absent = Branch(("c",), ("a", "b"), LaplaceEstimate(0.0, np.zeros(2)), 0.0)
    means = [np.array([0.1, -0.2, 0.3]), np.array([1.0, 0.5])]
    covariances = [COVARIANCE, COVARIANCE[:2, :2] * 0.5]
    shares = np.array([0.3, 0.7])
    z, which, log_q = _mixture_draws([present, absent], [[0, 1, 2], [0, 1]], means,
                                     covariances, shares, {"a": 0, "b": 1, "c": 2},
                                     {"c": 0.5}, 4000, rng)
    on_plateau = (z[:, 2] >= -0.5) & (z[:, 2] < 0.0)
    expected = np.logaddexp(
        math.log(0.3) + stats.multivariate_t(means[0], covariances[0], df=PROPOSAL_NU).logpdf(z),
        np.where(on_plateau, math.log(0.7) + math.log(2.0) + stats.multivariate_t(
            means[1], covariances[1], df=PROPOSAL_NU).logpdf(z[:, :2]), -np.inf))
    assert log_q == pytest.approx(expected, rel=1e-10)
    assert np.all(on_plateau[which == 1]) and abs(np.mean(which == 1) - 0.7) < 0.03


def _table2_h80() -> tuple:
    """table2_h80's config, its estimate settings, its onsets as the extractor finds them,
    and the same with the first onset cut off (numbered from 0)."""
    config = load_config(DATA / "table2_h80.toml")
    data = choose_roll(load_onsets(DATA / "table2_h80.flac")).data
    late = OnsetData(data.times[1:], data.sigmas[1:], np.asarray(data.bounces[1:]) - 1)
    return config, estimate_settings(config), data, late


@pytest.mark.slow
def test_the_screen_agrees_with_the_fitted_evidences():
    """table2_h80, whole and with its first onset cut off, each numbered from impacts 0, 1, 2,
    against the importance-sampled evidence of a fit: the Laplace screen within 1.5 nats where
    the numbering is within its margin (15 nats) of the roll's best, and beyond it where not
    (there it may miss the mode: the whole roll numbered from impact 2 screens 28 nats under
    its fit, both far under the best); the evidence sampled from the screen, where its
    diagnostic trusts it, within 0.25 nat (its own error a few hundredths)."""
    config, settings, data, late = _table2_h80()
    # The whole roll numbered from impact 2 mixes slowly and its evidence falls back to
    # nested sampling: a shorter chain and 50 live points (ln Z to ±0.7) still place it far
    # beyond the margin, and its fit takes a sixth of the time (13.6 s against 91 s).
    quick = replace(settings, live_points=50,
                    sampler=replace(settings.sampler, target_ess=300, max_steps=2500))
    trusted = 0
    for onsets in (data, late):
        fitted, found = {}, {}
        for missed in range(3):
            log_posterior = LogPosterior.build(config, config.model, shifted(onsets, missed),
                                               settings.noise, settings.nu)
            fitted[missed] = _fit(log_posterior, quick, 11)[1]
            assert fitted[missed].trusted
            found[missed] = screen(log_posterior, 3)
            sample = importance_sample(log_posterior, found[missed], 3)
            sampled = None if sample is None else sample.evidence
            if sampled is not None and sampled.trusted:
                trusted += 1
                assert sampled.log_z == pytest.approx(fitted[missed].log_z, abs=0.25)
        best = max(f.log_z for f in fitted.values())
        for missed, evidence in fitted.items():
            if evidence.log_z > best - SCREEN_NATS:
                assert found[missed].log_z == pytest.approx(evidence.log_z, abs=1.5)
            else:
                assert found[missed].log_z < best - SCREEN_NATS
    assert trusted >= 4


def test_a_branch_the_proposal_cannot_draw_from_voids_the_sampled_evidence():
    """table2_h80's screen (contact present and absent): with the present branch's Gaussian
    gone (−H not positive definite, as at a mode against a prior's edge) the proposal would
    hold the absent branch alone, and no weight could show the mass it misses: no estimate.
    Where the undrawn branch holds under 1 % of the screen's mass, the others' estimate
    stands."""
    config = load_config(DATA / "table2_h80.toml")
    settings = estimate_settings(config)
    data = choose_roll(load_onsets(DATA / "table2_h80.flac")).data
    log_posterior = LogPosterior.build(config, config.model, data, settings.noise, settings.nu)
    found = screen(log_posterior, 3)
    assert len(found.branches) == 2 and all(b.estimate.covariance is not None
                                            for b in found.branches)
    assert importance_sample(log_posterior, found, 3) is not None
    present, absent = found.branches

    def without_gaussian(branch: Branch, log_z: float) -> Branch:
        return replace(branch, estimate=replace(branch.estimate, covariance=None), log_z=log_z)

    heavy = (without_gaussian(present, present.log_z), absent)
    assert importance_sample(log_posterior, Screen(found.log_z, heavy), 3) is None
    light_log_z = absent.log_z + math.log(0.001)
    light = (without_gaussian(present, light_log_z), absent)
    total = float(np.logaddexp(light_log_z, absent.log_z))
    sample = importance_sample(log_posterior, Screen(total, light), 3)
    assert sample is not None and np.isfinite(sample.evidence.log_z)


@pytest.mark.skipif(not (CORPUS / "r06_pearl2_hard_release_96k.truth.json").exists(),
                    reason="the shared corpus is absent")
def test_a_numbering_whose_missed_flights_last_over_half_a_second_can_win():
    """Another simulator's roll (the shared corpus's r06: ODE impacts, released at 0.9 m/s)
    begun two impacts late, whose two missed flights last 0.53 s: under Student-t noise T0 (the
    time of impact 0) is sampled, and its prior window once ended 0.5 s before the first onset,
    which left numbering 2 38 nats below numbering 1 (with the pivot 5 sd off)."""
    import json

    truth = json.loads((CORPUS / "r06_pearl2_hard_release_96k.truth.json").read_text())
    times = np.asarray(truth["onset_times_s"])[2:]
    assert truth["onset_times_s"][2] - truth["onset_times_s"][0] > 0.5
    # table2_h80's stick and set-up (r06's: d = 131, h = 80 mm), Student-t noise
    raw = load_config(DATA / "table2_h80.toml").raw
    config = parse_config({**raw, "priors": {
        **raw["priors"], "release_speed_m_s": truth["release_tip_speed_m_s"]}})
    settings = estimate_settings(config)
    data = OnsetData.from_arrays(times, np.full(times.size, 1e-4))
    log_z = {}
    for missed in (1, 2):
        log_posterior = LogPosterior.build(config, config.model, shifted(data, missed),
                                           settings.noise, settings.nu)
        sample = importance_sample(log_posterior, screen(log_posterior, 1), 1)
        log_z[missed] = -math.inf if sample is None else sample.evidence.log_z
    assert log_z[2] > log_z[1] + 5.0


@pytest.mark.parametrize("first_flight", [0.05, 0.3, 1.5])
@pytest.mark.parametrize("alpha", [0.75, 0.9, 0.999])
@pytest.mark.parametrize("missed", [0, 1, 2, 3])
def test_t0_window_holds_impact_0_of_a_roll_numbered_from_a_later_impact(
        first_flight, alpha, missed):
    """A ball's impact times (eq. 9's geometric flights, with 0.1 ms jitter and 1 ms contact
    added to every interval), the first ``missed`` impacts not heard: impact 0 lies in the
    window T0's prior spans, for flights from 50 ms to 1.5 s; numbered from impact 0 the
    window is the first onset ± 0.5 s as before, and every numbering's window of a short roll
    is as wide (their evidences compare). (Until this window, impact 0 of a roll numbered
    from impact k > 0 was looked for in the second before the first onset: three missed
    flights of 0.3 s or longer lay outside it.)"""
    rng = np.random.default_rng(int(100 * first_flight) + missed)
    intervals = first_flight * alpha ** np.arange(16) + 1e-3
    times = 3.0 + np.concatenate(([0.0], np.cumsum(intervals))) + rng.normal(0, 1e-4, 17)
    data = shifted(OnsetData.from_arrays(times[missed:], np.full(17 - missed, 1e-4)), missed)
    low, high = t0_window(data)
    assert low < times[0] < high
    if missed == 0:
        assert (low, high) == pytest.approx((times[0] - 0.5, times[0] + 0.5))
    if first_flight * missed < 0.2:
        assert high - low == pytest.approx(1.0)


def test_a_numbering_the_evidences_reject_is_not_kept():
    """The fitted numbering clearly rejected (P ≤ 1 − CLEARLY) while no other is clearly
    preferred, the rest spread over two: the likeliest is fitted instead. A roll cut off
    after its first impact gave P = (3e-5, 0.93, 0.07), and the fit numbered from impact 0
    put α 7 sd from the truth; numbered from impact 1, 0.3 sd."""
    assert renumbering((3e-5, 0.93, 0.07)) == 1
    assert renumbering((0.01, 0.3, 0.69)) == 2
    assert renumbering({STRAY: 0.5, 0: 0.04, 1: 0.46}) == STRAY
    assert renumbering((0.06, 0.6, 0.34)) is None  # not rejected: kept, with a warning
    assert renumbering((0.04, math.nan, 0.0), numbered_from=1) is None  # its P unknown


def test_the_warning_names_the_likeliest_other_numbering():
    warning = missed_warning("pendulum", (0.3, 0.68, 0.02), numbered_from=1)
    assert "P(1 missed) = 0.68, P(0 missed) = 0.3" in warning
    assert "assume 1 was missed (the numbers over the numberings mix them)" in warning
    assert missed_warning("pendulum", (0.97, 0.03, 0.0)) is None


def test_only_numberings_of_some_weight_are_mixed():
    assert mixed_numberings((0.999, 0.001, 0.0)) == {}
    assert mixed_numberings((0.98, 0.02, 0.0)) == pytest.approx({0: 0.98, 1: 0.02})
    got = mixed_numberings((0.2, 0.5, 0.295, 0.005))
    assert got == pytest.approx({0: 0.2 / 0.995, 1: 0.5 / 0.995, 2: 0.295 / 0.995})
    # a tap taken for the first bounce is a numbering like the others
    assert mixed_numberings({STRAY: 0.7, 0: 0.3, 1: 0.0}) == pytest.approx({STRAY: 0.7, 0: 0.3})


def test_an_importance_sample_resamples_in_proportion_to_its_weights():
    x = np.array([[0.0], [1.0], [2.0]])
    log_w = np.array([np.log(0.25), np.log(0.75), -np.inf])
    sample = ImportanceSample(x, log_w, Evidence(0.0, 0.0, 3))
    drawn = sample.resampled(40_000, np.random.default_rng(0))[:, 0]
    assert np.mean(drawn == 1.0) == pytest.approx(0.75, abs=0.01)
    assert not np.any(drawn == 2.0)


def test_the_screens_importance_sample_is_the_numberings_posterior():
    """table2_h80 with its first onset cut off, numbered from impacts 0 and 1: α's mean and sd
    of the screen's importance sample, resampled, against a fit of the same numbering (emcee):
    within a fifth of an sd and 15 %, where the sample's diagnostic trusts it."""
    config, settings, _, late = _table2_h80()
    quick = replace(settings, sampler=replace(settings.sampler, target_ess=600))
    compared = 0
    for missed in (0, 1):
        log_posterior = LogPosterior.build(config, config.model, shifted(late, missed),
                                           settings.noise, settings.nu)
        sample = importance_sample(log_posterior, screen(log_posterior, 3), 3)
        if sample is None or not sample.evidence.trusted:
            continue
        compared += 1
        rng = np.random.default_rng(4)
        resampled = parameter_draws(log_posterior, sample.resampled(4000, rng)[None], rng)[0]
        chain = _fit(log_posterior, quick, 11)[0]
        fitted = parameter_draws(log_posterior, chain.samples, rng)[0]
        for key in ("alpha", "t_b", "pivot_mm"):
            sd = np.std(fitted[key])
            assert np.mean(resampled[key]) == pytest.approx(np.mean(fitted[key]), abs=0.2 * sd)
            assert np.std(resampled[key]) == pytest.approx(sd, rel=0.15)
    assert compared == 2


def test_a_numbering_without_draws_is_sampled_alike_in_one_process_or_two():
    """The average's fallback for a numbering with neither a fit nor a trusted importance
    sample: sampled as the main fit is, the same draws whether side by side or not, around
    the simulator's α."""
    config, settings, _, late = _table2_h80()
    quick = replace(settings, evidence="none",
                    sampler=replace(settings.sampler, target_ess=300))
    posteriors = {m: LogPosterior.build(config, config.model, shifted(late, m), settings.noise,
                                        settings.nu) for m in (1, 2)}
    alone = _sampled_draws(posteriors, quick, 5, workers=1)
    side_by_side = _sampled_draws(posteriors, quick, 5, workers=2)
    for m in (1, 2):
        np.testing.assert_array_equal(alone[m]["alpha"], side_by_side[m]["alpha"])
    alpha = alone[1]["alpha"]
    assert abs(alpha.mean() - 0.9) < 3 * alpha.std()
