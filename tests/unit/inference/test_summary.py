"""Posterior summaries and diagnostics (:mod:`drumroll.inference.summary`) on synthetic fits.

The InferenceData are built as in ``tests/unit/reporting/test_figures.py`` (``az.from_dict``
with the pipeline's groups), from seeded draws whose properties are known by construction
(AR(1) walkers, a group of walkers shifted, a posterior piled against its prior's bound):

* :func:`parameter_summary`: mean, sd and median against numpy, the HDI against ``arviz.hdi``,
  bulk and tail ESS against ``arviz.ess`` (walkers as chains), R-hat against ``arviz.rhat``
  of the walkers gathered into four groups (written out here with numpy);
* :func:`diagnostics`: each documented warning appears exactly when its target is missed
  (step limit, R-hat, ESS, acceptance, Pareto k, a prior's edge), only for the sampled
  parameters, and the figures it reports equal ArviZ's;
* :func:`flight_series`: the band equals ``np.quantile`` of the flattened draws;
* :func:`observed_flights`: flights between consecutive bounce numbers only, with errors
  from the posterior median jitter and the extractor's sigmas in quadrature (closed form).
"""

from __future__ import annotations

import math

import arviz as az
import numpy as np
import pytest

from drumroll.inference.comparison import LooResult
from drumroll.inference.sampling import Chain, SamplerSettings
from drumroll.inference.settings import EstimateSettings
from drumroll.inference.summary import (
    diagnostics,
    flight_series,
    observed_flights,
    parameter_summary,
)
from tests.unit.inference.test_sampling import _autocorrelated

WALKERS, DRAWS = 32, 300
BOUNCES = np.array([0, 1, 2, 4, 5, 6])  # bounce 3 unheard
T0 = 1.234


def _grouped(draws: np.ndarray, groups: int = 4) -> np.ndarray:
    """(walkers, n) → (groups, n × walkers / groups): consecutive walkers form a group, its
    walkers interleaved step by step (the nested R-hat's chains)."""
    walkers, n = draws.shape
    size = walkers // groups
    return draws[: groups * size].reshape(groups, size, n).transpose(0, 2, 1).reshape(groups, -1)


def _posterior(seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    shape = (WALKERS, DRAWS)
    return {
        "alpha": 0.88 + 0.002 * _autocorrelated(rng, shape, 0.5),
        "t_b": 0.25 + 1e-3 * np.round(_autocorrelated(rng, shape, 0.3), 1),  # ties
        "jitter_ms": np.exp(-1.0 + 0.3 * _autocorrelated(rng, shape, 0.7)),  # skewed
        "t0_s": T0 + 5e-5 * rng.standard_normal(shape),
    }


def _idata(posterior: dict[str, np.ndarray], *, prior: dict[str, np.ndarray] | None = None,
           sampled=("alpha", "t_b", "jitter_ms"), seed: int = 1) -> az.InferenceData:
    rng = np.random.default_rng(seed)
    shape = posterior["alpha"].shape
    k = np.arange(1, BOUNCES[-1] + 1)
    flights = posterior["t_b"][..., None] * posterior["alpha"][..., None] ** k
    impacts = np.concatenate([np.zeros((*shape, 1)), np.cumsum(flights, axis=-1)], axis=-1)
    mean = posterior["t0_s"][..., None] + impacts[..., BOUNCES]
    observed = T0 + np.r_[0.0, np.cumsum(0.25 * 0.88 ** k)][BOUNCES]
    observed = observed + 1e-4 * rng.standard_normal(BOUNCES.size)
    sigmas = np.array([1e-4, 2e-4, 0.0, 3e-4, 1e-4, 5e-4])
    scale = np.sqrt((posterior["jitter_ms"][..., None] * 1e-3) ** 2 + sigmas**2)
    log_lik = -0.5 * ((observed - mean) / scale) ** 2 - np.log(scale * math.sqrt(2 * math.pi))
    if prior is None:
        prior = {"alpha": rng.uniform(0.5, 1.0, (1, 2000)),
                 "t_b": rng.uniform(0.01, 2.0, (1, 2000)),
                 "jitter_ms": np.exp(rng.uniform(math.log(0.01), math.log(10), (1, 2000)))}
    idata = az.from_dict(
        posterior=posterior,
        posterior_predictive={"onset_time": mean + scale * rng.standard_normal(mean.shape),
                              "flight_time_model": flights},
        log_likelihood={"onset_time": log_lik}, observed_data={"onset_time": observed},
        constant_data={"onset_sigma_s": sigmas}, prior=prior,
        sample_stats={"lp": log_lik.sum(axis=-1)},
        coords={"onset": BOUNCES, "flight": k},
        dims={"onset_time": ["onset"], "flight_time_model": ["flight"],
              "onset_sigma_s": ["onset"]},
        attrs={"model": "powerlaw"})
    idata.sample_stats.attrs.update({"tau_parameters": list(sampled)})
    return idata


def _chain(*, converged: bool = True, acceptance: float = 0.4) -> Chain:
    return Chain(samples=np.zeros((WALKERS, DRAWS, 3)), log_prob=np.zeros((WALKERS, DRAWS)),
                 tau=np.array([12.0, np.inf, 30.0]), acceptance=acceptance, n_steps=3100,
                 burn=100, thin=10, converged=converged, mode=np.zeros(3), checks=3)


def _settings(target_ess: float = 1000.0, max_r_hat: float = 1.01) -> EstimateSettings:
    return EstimateSettings(sampler=SamplerSettings(target_ess=target_ess, max_r_hat=max_r_hat))


@pytest.fixture(scope="module")
def fit() -> az.InferenceData:
    return _idata(_posterior())


@pytest.mark.parametrize("hdi_prob", [0.9, 0.5])
def test_parameter_summary_equals_numpy_and_arviz(fit, hdi_prob):
    stats = parameter_summary(fit, hdi_prob)
    assert set(stats) == set(fit.posterior.data_vars)
    for name, s in stats.items():
        draws = np.asarray(fit.posterior[name])
        assert s.mean == pytest.approx(np.mean(draws), rel=1e-12)
        assert s.sd == pytest.approx(np.std(draws, ddof=1), rel=1e-10)
        assert s.median == pytest.approx(np.median(draws), rel=1e-12)
        low, high = az.hdi(draws.ravel(), hdi_prob=hdi_prob)
        assert (s.hdi_low, s.hdi_high, s.hdi_prob) == (pytest.approx(low, rel=1e-12),
                                                      pytest.approx(high, rel=1e-12), hdi_prob)
        assert s.ess_bulk == pytest.approx(az.ess(draws, method="bulk"), rel=1e-9)
        assert s.ess_tail == pytest.approx(az.ess(draws, method="tail"), rel=1e-9)
        assert s.r_hat == pytest.approx(az.rhat(_grouped(draws)), rel=1e-12)
    # the HDI of the skewed jitter is not the central interval
    jitter = np.asarray(fit.posterior["jitter_ms"])
    central = np.quantile(jitter, [(1 - hdi_prob) / 2, (1 + hdi_prob) / 2])
    assert stats["jitter_ms"].hdi_low < central[0]
    assert stats["jitter_ms"].hdi_high - stats["jitter_ms"].hdi_low < central[1] - central[0]


def test_parameter_summary_turns_undefined_numbers_into_none():
    posterior = _posterior()
    posterior["alpha"] = posterior["alpha"].copy()
    posterior["alpha"][3, 7] = np.nan
    stats = parameter_summary(_idata(posterior))
    assert stats["alpha"].mean is None and stats["alpha"].r_hat is None
    assert stats["t_b"].mean is not None


def test_good_run_has_no_warnings_and_arviz_figures(fit):
    d = diagnostics(fit, _chain(), None, _settings())
    assert d.warnings == ()
    assert (d.converged, d.n_steps, d.burn, d.thin, d.walkers, d.draws, d.checks) == (
        True, 3100, 100, 10, WALKERS, WALKERS * DRAWS, 3)
    assert d.tau_max == 30.0 and d.acceptance == 0.4  # the infinite tau left out
    sampled = ["alpha", "t_b", "jitter_ms"]
    draws = {n: np.asarray(fit.posterior[n]) for n in sampled}
    assert d.r_hat_max == pytest.approx(max(az.rhat(_grouped(v)) for v in draws.values()),
                                        rel=1e-12)
    assert d.ess_bulk_min == pytest.approx(min(az.ess(v, method="bulk")
                                               for v in draws.values()), rel=1e-9)
    assert d.ess_tail_min == pytest.approx(min(az.ess(v, method="tail")
                                               for v in draws.values()), rel=1e-9)
    assert (d.target_ess, d.max_r_hat) == (1000.0, 1.01)


def test_each_missed_target_is_warned_about(fit):
    def warned(idata=fit, chain=None, loo=None, settings=None):
        d = diagnostics(idata, chain or _chain(), loo, settings or _settings())
        return " | ".join(d.warnings), len(d.warnings)

    text, n = warned(chain=_chain(converged=False))
    assert n == 1 and "stopped at the step limit (3100 steps)" in text
    assert "raise [sampler] max_steps" in text

    for acceptance in (0.05, 0.85):
        text, n = warned(chain=_chain(acceptance=acceptance))
        assert n == 1 and f"acceptance fraction {acceptance:.2f} is outside" in text
    for acceptance in (0.1, 0.7):  # the ends are inside
        assert warned(chain=_chain(acceptance=acceptance))[1] == 0

    # ESS: the target above what the skewed, most autocorrelated jitter has
    ess = {n: min(az.ess(np.asarray(fit.posterior[n]), method=m) for m in ("bulk", "tail"))
           for n in ("alpha", "t_b", "jitter_ms")}
    target = 0.5 * (ess["jitter_ms"] + min(ess["alpha"], ess["t_b"]))
    assert ess["jitter_ms"] < target < min(ess["alpha"], ess["t_b"])
    text, n = warned(settings=_settings(target_ess=target))
    assert n == 1 and f"jitter_ms has only {ess['jitter_ms']:.0f} effective samples" in text

    loo = LooResult(elpd=0.0, se=0.0, pointwise=np.zeros(6),
                    pareto_k=np.array([0.9, 0.1, 0.2, 0.75, 0.3, 0.7]), bounces=BOUNCES)
    text, n = warned(loo=loo)
    assert n == 1 and "approximate for the onsets of bounces 0, 4 (Pareto k > 0.7)" in text
    loo = LooResult(elpd=0.0, se=0.0, pointwise=np.zeros(6),
                    pareto_k=np.array([0.1, 0.1, 0.2, 0.75, 0.3, 0.7]), bounces=BOUNCES)
    text, n = warned(loo=loo)
    assert n == 1
    assert "approximate for the onset of bounce 4 (Pareto k > 0.7): leaving it out" in text


def test_r_hat_warning_when_a_group_of_walkers_disagrees():
    posterior = _posterior()
    posterior["alpha"] = posterior["alpha"].copy()
    posterior["alpha"][:8] += 0.002  # one group of walkers off by a posterior sd
    idata = _idata(posterior)
    r_hat = az.rhat(_grouped(np.asarray(idata.posterior["alpha"])))
    assert r_hat > 1.01
    d = diagnostics(idata, _chain(), None, _settings(target_ess=100))  # (ESS drops too)
    assert d.warnings == (f"powerlaw: R-hat of alpha is {r_hat:.4f} (target < 1.01): the "
                          "walkers disagree; run longer",)
    assert d.r_hat_max == pytest.approx(r_hat, rel=1e-12)
    # a loose target accepts it
    assert diagnostics(idata, _chain(), None,
                       _settings(target_ess=100, max_r_hat=1.5)).warnings == ()


def test_only_sampled_parameters_are_diagnosed():
    """t0_s is not among ``tau_parameters``: its disagreement is not reported."""
    posterior = _posterior()
    posterior["t0_s"] = posterior["t0_s"].copy()
    posterior["t0_s"][:8] += 1.0
    assert diagnostics(_idata(posterior), _chain(), None, _settings()).warnings == ()


@pytest.mark.parametrize("edge", ["lower", "upper"])
def test_posterior_at_the_edge_of_its_prior(edge):
    """A jitter piled against 0.01 ms (the prior's lower end) or 10 ms (its upper end)."""
    posterior = _posterior()
    rng = np.random.default_rng(5)
    pile = np.abs(0.05 * rng.standard_normal((WALKERS, DRAWS)))
    posterior["jitter_ms"] = 0.01 + pile if edge == "lower" else 10.0 - pile
    idata = _idata(posterior)
    d = diagnostics(idata, _chain(), None, _settings())
    assert d.warnings == (f"powerlaw: jitter_ms piles up at the {edge} end of its prior: the "
                          "prior, not the data, sets that side of its interval",)
    # without a prior group there is nothing to compare with
    del idata.prior
    assert diagnostics(idata, _chain(), None, _settings()).warnings == ()


def test_a_contact_time_at_zero_says_what_it_does_to_alpha():
    """The contact time piled at its prior's 0: the warning says that α and t_B lean with it
    and that instantaneous impacts want contact_ms = 0 (benchmarks/corpus_truth.py)."""
    posterior = _posterior()
    rng = np.random.default_rng(6)
    posterior["contact_ms"] = np.abs(0.3 * rng.standard_normal((WALKERS, DRAWS)))
    prior = {"alpha": rng.uniform(0.5, 1.0, (1, 2000)), "t_b": rng.uniform(0.01, 2.0, (1, 2000)),
             "jitter_ms": np.exp(rng.uniform(math.log(0.01), math.log(10), (1, 2000))),
             "contact_ms": rng.uniform(0.0, 3.0, (1, 2000))}
    idata = _idata(posterior, prior=prior, sampled=("alpha", "t_b", "jitter_ms", "contact_ms"))
    (warning,) = diagnostics(idata, _chain(), None, _settings()).warnings
    assert warning.startswith("powerlaw: contact_ms piles up at the lower end of its prior")
    assert warning.endswith("α and t_B lean low with it, by about 1 sd if the impacts truly "
                            "have no contact: give the prior an atom at 0 (p_zero = 0.5, as "
                            "the default does) or say contact_ms = 0")


def test_a_contact_time_whose_prior_holds_zero_gives_its_probability_not_a_warning():
    """Under a prior with an atom at 0 (the default contact time), draws piled at 0 are the
    answer "no contact": no edge warning, and the summary gives P(τ_c = 0), the share of
    draws at 0; a quantity whose prior has no atom gets no probability."""
    posterior = _posterior()
    rng = np.random.default_rng(6)
    contact = np.maximum(rng.normal(-0.5, 0.6, (WALKERS, DRAWS)), 0.0)
    posterior["contact_ms"] = contact
    prior = {"alpha": rng.uniform(0.5, 1.0, (1, 2000)), "t_b": rng.uniform(0.01, 2.0, (1, 2000)),
             "jitter_ms": np.exp(rng.uniform(math.log(0.01), math.log(10), (1, 2000))),
             "contact_ms": np.maximum(rng.uniform(-3.0, 3.0, (1, 2000)), 0.0)}
    idata = _idata(posterior, prior=prior, sampled=("alpha", "t_b", "jitter_ms", "contact_ms"))
    assert diagnostics(idata, _chain(), None, _settings()).warnings == ()
    summary = parameter_summary(idata)
    assert summary["contact_ms"].probability_zero == pytest.approx(np.mean(contact == 0.0))
    assert 0.7 < summary["contact_ms"].probability_zero < 0.85  # Φ(0.5 / 0.6) = 0.80
    assert summary["alpha"].probability_zero is None


def test_flight_series_is_the_central_band_of_the_draws(fit):
    draws = np.asarray(fit.posterior_predictive["flight_time_model"]).reshape(-1, 6)
    for prob in (0.9, 0.5):
        series = flight_series(fit, prob)
        low, median, high = np.quantile(draws, [(1 - prob) / 2, 0.5, (1 + prob) / 2], axis=0)
        np.testing.assert_allclose(series.low, low, rtol=1e-12)
        np.testing.assert_allclose(series.median, median, rtol=1e-12)
        np.testing.assert_allclose(series.high, high, rtol=1e-12)
        assert series.prob == prob
        assert len(series.median) == BOUNCES[-1]
    # flights shrink with α = 0.88: T_k ≈ 0.25 × 0.88^k
    np.testing.assert_allclose(flight_series(fit).median, 0.25 * 0.88 ** np.arange(1, 7),
                               rtol=1e-3)


def test_observed_flights_skip_the_unheard_bounce(fit):
    times = np.asarray(fit.observed_data["onset_time"])
    sigmas = np.asarray(fit.constant_data["onset_sigma_s"])
    jitter = 1e-3 * np.median(np.asarray(fit.posterior["jitter_ms"]))
    got = observed_flights(fit)
    # onsets are bounces 0, 1, 2, 4, 5, 6: flights 1, 2, 5, 6 observed; 3 and 4 span the gap
    want = [times[1] - times[0], times[2] - times[1], None, None, times[4] - times[3],
            times[5] - times[4]]
    assert got.time_s[2:4] == (None, None)
    np.testing.assert_allclose([got.time_s[i] for i in (0, 1, 4, 5)],
                               [want[i] for i in (0, 1, 4, 5)], rtol=1e-12)
    pairs = {0: (0, 1), 1: (1, 2), 4: (3, 4), 5: (4, 5)}
    for flight, (a, b) in pairs.items():
        err = math.sqrt(2 * jitter**2 + sigmas[a] ** 2 + sigmas[b] ** 2)
        assert got.err_s[flight] == pytest.approx(err, rel=1e-12)
    assert got.err_s[2:4] == (None, None)


def test_observed_flights_without_jitter_or_sigmas():
    """A model without jitter and a fit without extractor sigmas: the errors are 0."""
    posterior = _posterior()
    idata = _idata(posterior)
    del idata.posterior["jitter_ms"]
    del idata.constant_data
    got = observed_flights(idata)
    assert [e for e in got.err_s if e is not None] == [0.0] * 4
