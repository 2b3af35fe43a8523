"""Model comparison (:mod:`drumroll.inference.comparison`) on cases whose answer is known.

* :func:`loo` equals ``arviz.loo`` on the same InferenceData (elpd, its standard error, the
  pointwise values and Pareto k), and names onsets by the ``onset`` coordinate;
* :func:`compare_models` on fits whose log-likelihoods differ by a known constant per onset
  c_i (the same for every draw, so PSIS-LOO's pointwise values differ by exactly c_i):
  Δelpd = Σ c_i and its standard error √(n Var c_i), as ``arviz.compare`` gives them, with the
  sign main − other; the verdict and the preferred model follow the documented thresholds
  (|Δelpd| > 4 and > 2 se; |ln B| > 1 and > 2 errors; neither deciding against the other);
* Bayes factors are the given evidences' difference, with their errors in quadrature.
"""

from __future__ import annotations

import math
import warnings

import arviz as az
import numpy as np
import pytest

from drumroll.inference.comparison import (
    BF_MIN,
    LOO_MIN_DIFF,
    SIGMAS,
    LooResult,
    compare_models,
    decide,
    loo,
)
from drumroll.inference.evidence import Evidence

N = 12
BOUNCES = np.array([0, 1, 2, 3, 5, 6, 7, 8, 9, 10, 11, 13])  # bounces 4 and 12 unheard


def _idata(shift: np.ndarray | float = 0.0, *, seed: int = 0, coords: bool = True,
           outlier: float = 0.0) -> az.InferenceData:
    """A Gaussian location model's fit to N points, 4 chains × 250 draws; ``shift`` is added
    to every draw's log-likelihood of each point (per point), ``outlier`` to the last
    observation (a badly fitting point gives a large Pareto k)."""
    rng = np.random.default_rng(seed)
    y = np.random.default_rng(100).normal(0.0, 1.0, N)
    y[-1] += outlier
    mu = y.mean() + rng.normal(0.0, 1.0 / math.sqrt(N), (4, 250))
    log_lik = -0.5 * (y - mu[..., None]) ** 2 - 0.5 * math.log(2 * math.pi) + shift
    kwargs = {}
    if coords:
        kwargs = {"coords": {"onset": BOUNCES}, "dims": {"onset_time": ["onset"]}}
    return az.from_dict(posterior={"mu": mu}, log_likelihood={"onset_time": log_lik},
                        observed_data={"onset_time": y}, **kwargs)


def _az_loo(idata):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return az.loo(idata, pointwise=True)


@pytest.mark.parametrize("coords", [True, False])
@pytest.mark.parametrize("outlier", [0.0, 8.0])
def test_loo_equals_arviz(coords, outlier):
    idata = _idata(coords=coords, outlier=outlier)
    ours, ref = loo(idata), _az_loo(idata)
    assert ours.elpd == pytest.approx(float(ref.elpd_loo), rel=1e-12)
    assert ours.se == pytest.approx(float(ref.se), rel=1e-12)
    np.testing.assert_allclose(ours.pointwise, np.asarray(ref.loo_i), rtol=1e-12)
    np.testing.assert_allclose(ours.pareto_k, np.asarray(ref.pareto_k), rtol=1e-12)
    assert ours.pointwise.sum() == pytest.approx(ours.elpd, rel=1e-12)
    if coords:
        np.testing.assert_array_equal(ours.bounces, BOUNCES)
    else:
        assert ours.bounces is None
    bad = np.flatnonzero(np.asarray(ref.pareto_k) > 0.7)
    names = BOUNCES[bad] if coords else bad
    assert ours.bad_onsets == [int(b) for b in names]
    assert ours.summary().pareto_k_bad == tuple(ours.bad_onsets)
    assert ours.summary().elpd_loo == ours.elpd
    if outlier:  # the constructed misfit is flagged, by its bounce number
        assert ours.bad_onsets == [13 if coords else N - 1]


def test_loo_raises_no_warning_for_bad_pareto_k():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = loo(_idata(outlier=8.0))
    assert result.bad_onsets


def _shifts(total: float, spread: float, seed: int = 1) -> np.ndarray:
    """Per-point log-likelihood shifts summing to ``total`` with sd ``spread``."""
    c = np.random.default_rng(seed).normal(0.0, 1.0, N)
    c = (c - c.mean()) / c.std() * spread
    return c + total / N


def _compare(idatas, main, evidences=None):
    return compare_models(idatas, main, evidences)


def test_known_difference_equals_arviz_compare():
    shift = _shifts(10.0, 0.2)
    idatas = {"good": _idata(shift), "plain": _idata()}
    rows, preferred, verdict, loos = _compare(idatas, "good")
    (row,) = rows
    assert row.model == "plain"
    # main − other: the shifted fit is better by exactly Σ c_i, se √(n Var c_i)
    assert row.elpd_loo_diff == pytest.approx(shift.sum(), rel=1e-9)
    assert row.elpd_loo_diff_se == pytest.approx(math.sqrt(N) * shift.std(), rel=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = az.compare(idatas, ic="loo")
    assert row.elpd_loo_diff == pytest.approx(table.loc["plain", "elpd_diff"], rel=1e-9)
    assert row.elpd_loo_diff_se == pytest.approx(table.loc["plain", "dse"], rel=1e-9)
    assert row.elpd_loo == pytest.approx(table.loc["plain", "elpd_loo"], rel=1e-12)
    assert row.elpd_loo_se == pytest.approx(table.loc["plain", "se"], rel=1e-12)
    assert row.log_bayes_factor is None and row.log_bayes_factor_err is None
    assert preferred == "good"
    assert verdict.startswith("good is preferred over plain (Δelpd = 10.0 ± 0.7")
    assert set(loos) == {"good", "plain"}
    assert loos["good"].elpd == pytest.approx(_az_loo(idatas["good"]).elpd_loo, rel=1e-12)


def test_sign_is_main_minus_other():
    idatas = {"plain": _idata(), "good": _idata(_shifts(10.0, 0.2))}
    (row,), preferred, verdict, _ = _compare(idatas, "plain")
    assert row.elpd_loo_diff == pytest.approx(-10.0, rel=1e-9)
    assert preferred == "good"
    assert verdict.startswith("good is preferred over plain (Δelpd = -10.0 ±")
    assert "signs are plain − good" in verdict


@pytest.mark.parametrize(("total", "spread", "why"), [
    (3.0, 0.05, "below 4"),
    (6.0, 1.0, "under two standard errors"),  # se = √12 ≈ 3.5
    (0.0, 0.0, "identical"),
])
def test_unclear_differences_are_not_a_preference(total, spread, why):
    idatas = {"a": _idata(_shifts(total, spread)), "b": _idata()}
    (row,), preferred, verdict, _ = _compare(idatas, "a")
    assert row.elpd_loo_diff == pytest.approx(total, abs=1e-9), why
    assert preferred is None, why
    assert verdict.startswith("the data cannot tell a from b"), why


def test_a_single_model_has_nothing_to_compare():
    rows, preferred, verdict, loos = _compare({"only": _idata()}, "only")
    assert rows == () and verdict == "no other model was fitted"
    assert preferred == "only"  # vacuously better than every other one
    assert set(loos) == {"only"}


def test_precomputed_loos_are_used():
    idatas = {"a": _idata(_shifts(10.0, 0.2)), "b": _idata()}
    fake = LooResult(elpd=-1.0, se=0.1, pointwise=np.full(N, 5.0), pareto_k=np.zeros(N))
    (row,), _, _, loos = compare_models(idatas, "a", loos={"b": fake})
    assert loos["b"] is fake
    assert row.elpd_loo_diff == pytest.approx(loos["a"].pointwise.sum() - 5.0 * N, rel=1e-12)


def test_three_models_the_clear_winner_is_preferred():
    """Model ``best`` beats the main model by 20 and a third model is 10 behind it or 10
    ahead of it: ``best`` is clearly better than every other one. Two models equally far
    ahead of the main one: no preference."""
    base = _idata()
    best = _idata(_shifts(20.0, 0.2, seed=2))
    for third in (-10.0, 10.0):
        idatas = {"base": base, "best": best, "third": _idata(_shifts(third, 0.2, seed=3))}
        _, preferred, verdict, _ = _compare(idatas, "base")
        assert "best is preferred over base" in verdict
        assert preferred == "best", third
    twin = _idata(_shifts(20.0, 0.2, seed=4))
    _, preferred, _, _ = _compare({"base": base, "best": best, "twin": twin}, "base")
    assert preferred is None
    _, preferred, _, _ = _compare({"base": base, "best": best, "twin": twin}, "best")
    assert preferred is None  # best cannot be told from twin


def test_bayes_factor_from_evidences():
    idatas = {"a": _idata(), "b": _idata()}  # LOO cannot tell them apart
    evidences = {"a": Evidence(log_z=-100.0, log_z_err=0.3, n_calls=1),
                 "b": Evidence(log_z=-103.5, log_z_err=0.4, n_calls=1)}
    (row,), preferred, verdict, _ = _compare(idatas, "a", evidences)
    assert row.log_bayes_factor == pytest.approx(3.5)
    assert row.log_bayes_factor_err == pytest.approx(0.5)  # 0.3 and 0.4 in quadrature
    assert preferred == "a"
    assert verdict == ("a is preferred over b (Δelpd = 0.0 ± 0.0, log BF = 3.5 ± 0.5)")
    # a small evidence error is printed with one significant digit
    precise = {k: Evidence(e.log_z, 0.006, 1) for k, e in evidences.items()}
    _, _, verdict, _ = _compare(idatas, "a", precise)
    assert "log BF = 3.500 ± 0.008" in verdict
    # evidence for only one model: no Bayes factor
    (row,), preferred, _, _ = _compare(idatas, "a", {"a": evidences["a"]})
    assert row.log_bayes_factor is None and preferred is None


def test_bayes_factor_and_loo_disagreeing_is_no_preference():
    idatas = {"a": _idata(_shifts(10.0, 0.2)), "b": _idata()}
    against = {"a": Evidence(-110.0, 0.1, 1), "b": Evidence(-100.0, 0.1, 1)}
    (row,), preferred, verdict, _ = _compare(idatas, "a", against)
    assert row.log_bayes_factor == pytest.approx(-10.0)
    assert preferred is None
    assert verdict.startswith("the data cannot tell a from b")


@pytest.mark.parametrize(("args", "want"), [
    ((4.5, 1.0), 1), ((-4.5, 1.0), -1), ((3.9, 0.1), 0), ((10.0, 5.0), 0),
    ((10.0, 4.9), 1), ((0.0, 0.0, 1.5, 0.2), 1), ((0.0, 0.0, -1.5, 0.2), -1),
    ((0.0, 0.0, 1.5, 0.8), 0), ((0.0, 0.0, 0.9, 0.0), 0), ((0.0, 0.0, 1.1, None), 1),
    ((10.0, 1.0, 0.5, 0.1), 1), ((10.0, 1.0, -0.5, 0.1), 1), ((10.0, 1.0, -5.0, 0.1), 0),
    ((2.0, 0.1, 5.0, 0.1), 1), ((-10.0, 1.0, -5.0, 0.1), -1),
])
def test_decide_follows_the_documented_thresholds(args, want):
    assert (LOO_MIN_DIFF, SIGMAS, BF_MIN) == (4.0, 2.0, 1.0)  # the thresholds these cases use
    assert decide(*args) == want
