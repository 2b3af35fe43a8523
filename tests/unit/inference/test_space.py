"""A model's parameter space (:class:`~drumroll.inference.space.ParameterSpace`).

Checked against what is known by construction and against references outside the module:

* the column order is the model's physical parameters in the forward model's order, then the
  jitter, then the stick's uncertain dimensions, then the likelihood's extra parameters; a
  parameter given a number is fixed (no column) and appears in :meth:`values` as that number;
* :meth:`log_prior` and :meth:`log_prior_one` equal the priors' log densities summed by hand
  (each :class:`~drumroll.distributions.Distribution` on its own column), and for the paper's
  set-up the ``scipy.stats`` densities summed; −inf outside any support;
* :meth:`sample_prior` stays inside every support, and each column's draws follow that
  column's prior (Kolmogorov–Smirnov against its truncated CDF built from scipy);
* :meth:`bounces` and :meth:`impacts` equal :func:`drumroll.physics.bounce_sequence` called
  directly with the same values (and the fixed ones, and the stick);
* an unknown model name raises.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from drumroll.config import parse_config
from drumroll.distributions import Fixed, HalfNormal, Normal, OrZero, Uniform
from drumroll.errors import ConfigError
from drumroll.inference.space import DEFAULT_CONTACT_PRIOR, DEFAULT_JITTER_PRIOR, ParameterSpace
from drumroll.physics import StickGeometry, bounce_sequence
from drumroll.physics.bounces import RIM_FIRST
from drumroll.physics.models import MODELS
from tests.unit.inference.test_posterior import _config

VARIANTS = ("table1", "release", "thin-rod", "radius")
STICK = ("stick_length", "stick_tip", "stick_radius")


def _expected_names(config, model: str) -> tuple[str, ...]:
    """The column order written out: physics, jitter, contact time (sampled by default),
    stick, each only if not fixed."""
    forward = MODELS[model]
    order = [*forward.parameters, "jitter", "contact", *(STICK if forward.needs_stick else ())]
    every = {"contact": DEFAULT_CONTACT_PRIOR, **config.priors}
    if forward.needs_stick:
        every.update(stick_length=config.stick.length, stick_tip=config.stick.tip,
                     stick_radius=config.stick.radius)
    return tuple(n for n in order if not every[n].is_fixed)


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("model", sorted(MODELS))
def test_columns_are_the_sampled_parameters_in_order(model, variant):
    config = _config(variant)
    space = ParameterSpace.build(config, model)
    assert space.names == _expected_names(config, model)
    assert space.ndim == len(space.names)
    assert space.extra == ()
    for name in (*MODELS[model].parameters, "jitter"):  # the config's own priors
        assert space.priors[name] == config.priors[name], name
    if MODELS[model].needs_stick:
        for name in STICK:
            assert space.priors[name] == getattr(config.stick, name.removeprefix("stick_"))
    fixed = {n for n, p in space.priors.items() if p.is_fixed}
    assert fixed.isdisjoint(space.names)
    assert set(space.names) | fixed == set(space.priors)
    x = space.sample_prior(np.random.default_rng(0), 5)
    values = space.values(x)
    for i, name in enumerate(space.names):
        # a prior with an atom at 0 is sampled through a coordinate: its negative half is 0
        want = np.maximum(x[:, i], 0.0) if isinstance(space.priors[name], OrZero) else x[:, i]
        np.testing.assert_array_equal(values[name], want)
        np.testing.assert_array_equal(space.value(x, name), want)
    for name in fixed:
        assert values[name] == space.priors[name].value == space.value(x, name)


def test_table1_pendulum_by_hand():
    """The paper's set-up: release fixed at rest, the radius fixed at 7.5 mm."""
    space = ParameterSpace.build(_config("table1"), "pendulum")
    assert space.names == ("alpha", "pivot", "height", "jitter", "contact", "stick_length",
                           "stick_tip")
    # the default: none or 0-3 ms, at even odds
    assert space.priors["contact"] == OrZero(Uniform(low=0.0, high=3e-3), p_zero=0.5)
    assert space.priors["stick_radius"] == Fixed(0.0075)
    assert space.priors["release_speed"] == Fixed(0.0)
    assert "t_b" not in space.priors  # the pendulum derives t_B


def test_default_jitter_and_extra_priors():
    raw = {"model": "powerlaw", "priors": {"alpha": {"dist": "uniform", "low": 0.5, "high": 1},
                                           "t_b": 0.3}}
    config = parse_config(raw)
    nu = HalfNormal(sigma=10.0, lower=1.0)
    space = ParameterSpace.build(config, "powerlaw",
                                 {"t0": Normal(mu=1.0, sigma=0.1), "nu": nu, "skew": Fixed(2.0)})
    assert space.priors["jitter"] is DEFAULT_JITTER_PRIOR
    assert space.priors["contact"] is DEFAULT_CONTACT_PRIOR
    assert space.names == ("alpha", "jitter", "contact", "t0", "nu")  # t_b fixed, extras last
    assert space.extra == ("t0", "nu")
    x = np.array([[0.8, 1e-3, 1e-3, 1.05, 3.0]])
    want = (math.log(2.0) + stats.loguniform(1e-5, 1e-2).logpdf(1e-3) + math.log(0.5 / 3e-3)
            + stats.norm(1.0, 0.1).logpdf(1.05)
            + stats.halfnorm(scale=10).logpdf(3.0) - math.log(stats.halfnorm(scale=10).sf(1.0)))
    assert space.log_prior(x)[0] == pytest.approx(want, rel=1e-12)
    assert space.values(x)["t_b"] == 0.3 and space.values(x)["skew"] == 2.0


def test_log_prior_of_the_paper_set_up_equals_scipy():
    """alpha ~ U(0.5, 1), d ~ N(131, 2) mm, h ~ N(80, 3) mm, jitter log-uniform 0.01–10 ms,
    l1 ~ N(348, 1) mm, l2 ~ N(60, 1) mm (all far from their lower bound 0: no truncation
    mass to speak of)."""
    space = ParameterSpace.build(_config("table1"), "pendulum")
    refs = [stats.uniform(0.5, 0.5), stats.norm(0.131, 0.002), stats.norm(0.080, 0.003),
            # the contact time's coordinate: none (below 0) or 0-3 ms at even odds
            stats.loguniform(1e-5, 1e-2), stats.uniform(-3e-3, 6e-3), stats.norm(0.348, 0.001),
            stats.norm(0.060, 0.001)]
    x = space.sample_prior(np.random.default_rng(1), 200)
    want = sum(ref.logpdf(x[:, i]) for i, ref in enumerate(refs))
    np.testing.assert_allclose(space.log_prior(x), want, rtol=1e-12)
    np.testing.assert_allclose([space.log_prior_one(row) for row in x], want, rtol=1e-12)


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("model", sorted(MODELS))
def test_log_prior_is_the_sum_of_the_columns_densities(model, variant):
    space = ParameterSpace.build(_config(variant), model)
    rng = np.random.default_rng(len(model) * 10 + len(variant))
    x = space.sample_prior(rng, 300)
    x[:40] += rng.normal(0, 3, (40, space.ndim)) * np.std(x, axis=0)  # many outside
    x[40, 0] = np.nan
    by_hand = np.zeros(x.shape[0])
    for i, name in enumerate(space.names):
        by_hand = by_hand + space.priors[name].logpdf(x[:, i])
    got = space.log_prior(x)
    one = np.array([space.log_prior_one(row) for row in x])
    finite = np.isfinite(by_hand)
    assert 200 < finite.sum() < 300
    for value in (got, one):
        assert np.all(value[~finite] == -np.inf)
        np.testing.assert_allclose(value[finite], by_hand[finite], rtol=1e-12, atol=1e-12)
    assert space.log_prior(x[5]).shape == (1,)


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("model", ["pendulum", "powerlaw"])
def test_prior_draws_stay_inside_and_follow_each_prior(model, variant):
    space = ParameterSpace.build(_config(variant), model)
    draws = space.sample_prior(np.random.default_rng(7), 3000)
    assert draws.shape == (3000, space.ndim)
    assert np.all(np.isfinite(space.log_prior(draws)))
    for i, name in enumerate(space.names):
        prior = space.priors[name]
        lo, hi = prior.support
        assert np.all((draws[:, i] >= lo) & (draws[:, i] <= hi)), name
        if isinstance(prior, OrZero):  # the default contact time: uniform on [−3, 3] ms
            assert prior.slab == Uniform(low=0.0, high=3e-3) and prior.p_zero == 0.5
            result = stats.kstest(draws[:, i], stats.uniform(-3e-3, 6e-3).cdf)
            assert result.pvalue > 1e-3, name
            continue
        # the truncated CDF from the family's own kernel is checked against scipy in
        # tests/unit/test_distributions.py; here: the draws follow it
        c_lo = prior.cdf(lo, *prior.param_values)
        result = stats.kstest(draws[:, i],
                              lambda v, p=prior, c=c_lo: (p.cdf(v, *p.param_values) - c) / p.mass)
        assert result.pvalue > 1e-3, name
    # independent columns
    corr = np.corrcoef(draws.T)
    np.testing.assert_allclose(corr, np.eye(space.ndim), atol=0.08)


def _direct(space: ParameterSpace, x: np.ndarray, n: int):
    """``bounce_sequence`` called with the values written out from the config."""
    config = space.config
    col = dict(zip(space.names, x.T, strict=True))

    def get(name):
        return col[name] if name in col else space.priors[name].value

    law = ({"restitution_exponent": get("restitution_exponent")}
           if "restitution_exponent" in space.priors else {})
    if not space.forward.needs_stick:
        return bounce_sequence(space.model, alpha=get("alpha"), t_b=get("t_b"), n_flights=n,
                               **law)
    stick = StickGeometry(config.stick.shape, get("stick_length"), get("stick_tip"),
                          get("stick_radius"))
    bounces = bounce_sequence(space.model, alpha=get("alpha"), pivot=get("pivot"),
                              height=get("height"), release_speed=get("release_speed"),
                              release_angle=get("release_angle"), stick=stick, n_flights=n,
                              g=config.gravity, **law)
    if config.stick.shape == "thin-rod":
        return bounces
    # A run is held to tip contact: the contact angle asin(h / (L − d)) at least the cone's
    # half-angle atan(R / l2), else the rim strikes first (physics.md).
    arm = get("stick_length") + get("stick_tip") - get("pivot")
    rim = np.arcsin(np.clip(get("height") / arm, -1, 1)) < np.arctan2(get("stick_radius"),
                                                                       get("stick_tip"))
    return bounces.invalidated(np.broadcast_to(rim, bounces.reason.shape), RIM_FIRST)


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("model", sorted(MODELS))
def test_impacts_and_bounces_equal_the_forward_model(model, variant):
    space = ParameterSpace.build(_config(variant), model)
    x = space.sample_prior(np.random.default_rng(9), 200)
    x[0, 0] = 1.3  # alpha > 1: no drumroll
    direct = _direct(space, x, 12)
    assert 50 < direct.valid.sum() < 200
    bounces = space.bounces(x, 12)
    np.testing.assert_array_equal(bounces.valid, direct.valid)
    np.testing.assert_array_equal(bounces.impacts, direct.impacts)  # NaN where invalid
    impacts, valid = space.impacts(x, 12)
    assert impacts.shape == (200, 13)
    np.testing.assert_array_equal(valid, direct.valid)
    # the sampler's impacts carry the contact time (sampled by default, the constant law):
    # impact m comes m τ_c after the flights alone put it
    delayed = direct.impacts + space.value(x, "contact")[:, None] * np.arange(13)
    np.testing.assert_allclose(impacts[valid], delayed[valid], rtol=1e-12, atol=1e-15)
    assert space.impacts_one(x[0], 12) is None
    good = int(np.flatnonzero(valid)[0])
    np.testing.assert_allclose(space.impacts_one(x[good], 12), delayed[good],
                               rtol=1e-12, atol=1e-15)


def test_impacts_with_every_physical_parameter_fixed():
    """Only the jitter sampled: one sequence, repeated for every row."""
    raw = {"model": "powerlaw", "priors": {"alpha": 0.9, "t_b": 0.25, "contact_ms": 0}}
    space = ParameterSpace.build(parse_config(raw), "powerlaw")
    assert space.names == ("jitter",)
    impacts, valid = space.impacts(np.full((4, 1), 1e-3), 5)
    assert impacts.shape == (4, 6) and valid.all()
    want = np.r_[0.0, np.cumsum(0.25 * 0.9 ** np.arange(1, 6))]
    np.testing.assert_allclose(impacts, np.broadcast_to(want, (4, 6)), rtol=1e-14)


def test_unknown_model_is_refused():
    config = _config("table1")
    with pytest.raises(ValueError, match=r"unknown model 'bouncing-ball'.*powerlaw"):
        ParameterSpace.build(config, "bouncing-ball")


def test_the_power_laws_default_t_b_prior_is_the_geometrys_prior_predictive():
    """Left out of a config with a [stick], t_B's prior is the exact pendulum's prior
    predictive (issue 13), not a flat range: checked against the geometry's draws run through
    the public forward model by hand; without a stick t_B is still required."""
    raw = {"model": "pendulum", "compare": ["powerlaw"],
           "stick": {"shape": "cylinder-cone", "length_mm": 348, "tip_mm": 60, "radius_mm": 7.5},
           "priors": {"alpha": {"dist": "uniform", "low": 0.5, "high": 1.0},
                      "pivot_mm": {"dist": "normal", "mu": 131, "sigma": 2},
                      "height_mm": {"dist": "normal", "mu": 50, "sigma": 3}}}
    prior = ParameterSpace.build(parse_config(raw), "powerlaw").priors["t_b"]
    rng = np.random.default_rng(1)
    pivot, height = rng.normal(0.131, 0.002, 50_000), rng.normal(0.050, 0.003, 50_000)
    stick = StickGeometry("cylinder-cone", 0.348, 0.06, 0.0075)
    t_b = bounce_sequence("pendulum", alpha=0.9, pivot=pivot, height=height, stick=stick,
                          n_flights=0).t_b
    assert prior.median() == pytest.approx(np.median(t_b), rel=2e-3)
    assert prior.sigma == pytest.approx(np.std(np.log(t_b)), rel=0.03)
    del raw["stick"]
    raw["model"] = "powerlaw"
    raw["compare"] = []
    with pytest.raises(ConfigError, match="t_b: missing"):
        parse_config(raw)
