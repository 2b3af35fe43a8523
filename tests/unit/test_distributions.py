"""The prior families of :mod:`drumroll.distributions`, against ``scipy.stats``.

Every family registered in :data:`~drumroll.distributions.FAMILIES` has a reference here
(:data:`REFERENCE`: the same family as a frozen ``scipy.stats`` distribution, plus parameter
sets); a family added without one fails :func:`test_every_family_has_a_scipy_reference`, and
each check below runs on every family, untruncated and truncated:

* ``logpdf`` equals scipy's log density minus the log of the truncation's mass (scipy's CDF
  at the two bounds), −inf outside; an array mixing inside and outside points gives, point
  by point, what each point gives alone (the fast path and the substituting path agree);
* the family's ``cdf`` and ``quantile`` kernels equal scipy's ``cdf`` and ``ppf``;
* ``ppf`` equals the truncated quantile built from scipy (and inverts the truncated CDF);
  ``median`` is its value at one half; ``mass`` is scipy's probability of the interval;
* the truncated density integrates to one (``scipy.integrate.quad``);
* ``sample`` stays inside the support and passes a Kolmogorov–Smirnov test against the
  truncated CDF built from scipy (seeded);
* ``scaled(f)`` is the law of f·X (change of variables), and refuses f ≤ 0;
* a normal truncated to an interval equals ``scipy.stats.truncnorm``.

:class:`~drumroll.distributions.Fixed` is checked by its definition, and bad parameters
reaching :func:`drumroll.config.priors_section.parse_prior` raise
:class:`~drumroll.errors.ConfigError` naming the key.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import integrate, stats

from drumroll.config.priors_section import parse_prior
from drumroll.distributions import FAMILIES, Fixed, HalfNormal, Normal, OrZero, Truncated
from drumroll.errors import ConfigError
from drumroll.quantities import QUANTITIES

#: Each family: parameter sets, and the same law as a frozen scipy distribution.
REFERENCE = {
    "uniform": ([{"low": -1.0, "high": 3.0}, {"low": 0.2, "high": 0.25}],
                lambda p: stats.uniform(loc=p["low"], scale=p["high"] - p["low"])),
    "loguniform": ([{"low": 1e-5, "high": 1e-2}, {"low": 0.5, "high": 40.0}],
                   lambda p: stats.loguniform(p["low"], p["high"])),
    "normal": ([{"mu": 131.0, "sigma": 2.0}, {"mu": -0.3, "sigma": 0.05}],
               lambda p: stats.norm(loc=p["mu"], scale=p["sigma"])),
    "halfnormal": ([{"sigma": 0.5}, {"sigma": 30.0}],
                   lambda p: stats.halfnorm(scale=p["sigma"])),
    "lognormal": ([{"mu": math.log(131.0), "sigma": 0.3}, {"mu": -2.0, "sigma": 1.5}],
                  lambda p: stats.lognorm(s=p["sigma"], scale=math.exp(p["mu"]))),
    "beta": ([{"a": 20.0, "b": 3.0}, {"a": 0.7, "b": 1.8, "low": 2.0, "high": 5.0},
              {"a": 2.0, "b": 2.0, "low": -1.0, "high": 1.0}],
             lambda p: stats.beta(p["a"], p["b"], loc=p.get("low", 0.0),
                                  scale=p.get("high", 1.0) - p.get("low", 0.0))),
}


def _cases():
    for family, (param_sets, _) in REFERENCE.items():
        for i, params in enumerate(param_sets):
            for cut in ("whole", "truncated"):
                yield pytest.param(family, params, cut, id=f"{family}-{i}-{cut}")


CASES = list(_cases())


def _build(family: str, params: dict, cut: str):
    """Our prior and scipy's untruncated law, with the truncation bounds ``(lo, hi)``."""
    cls = FAMILIES[family][0]
    ref = REFERENCE[family][1](params)
    prior = cls(**params)
    if cut == "truncated":  # cut away 15 % below and 25 % above
        lo, hi = float(ref.ppf(0.15)), float(ref.ppf(0.75))
        prior = prior.truncated(lo, hi)
    else:
        lo, hi = (float(v) for v in ref.support())
    return prior, ref, lo, hi


def _inside(lo: float, hi: float, n: int = 41) -> np.ndarray:
    """``n`` points strictly inside [lo, hi]."""
    return np.linspace(lo, hi, n + 2)[1:-1]


def _grid(ref, lo: float, hi: float) -> np.ndarray:
    """Points inside [lo, hi] and inside scipy's 1e-6 … 1 − 1e-6 quantile range."""
    a, b = max(lo, float(ref.ppf(1e-6))), min(hi, float(ref.ppf(1 - 1e-6)))
    return _inside(a, b)


def test_every_family_has_a_scipy_reference():
    assert set(REFERENCE) == set(FAMILIES)
    for family, (cls, required, optional) in FAMILIES.items():
        assert issubclass(cls, Truncated)
        for params in REFERENCE[family][0]:
            assert set(required) <= set(params) <= set(required) | set(optional)


@pytest.mark.parametrize(("family", "params", "cut"), CASES)
def test_logpdf_equals_scipy_renormalised(family, params, cut):
    prior, ref, lo, hi = _build(family, params, cut)
    assert prior.support == pytest.approx((lo, hi))
    mass = ref.cdf(hi) - ref.cdf(lo)
    assert prior.mass == pytest.approx(mass, rel=1e-10)
    assert prior.log_mass == pytest.approx(math.log(mass), abs=1e-10)
    x = _grid(ref, lo, hi)
    np.testing.assert_allclose(prior.logpdf(x), ref.logpdf(x) - math.log(mass),
                               rtol=1e-9, atol=1e-9)
    outside = np.array([lo - 1.0, lo - 1e-9 * max(1.0, abs(lo)), hi + 1e-9 * max(1.0, abs(hi)),
                        hi + 1.0])
    outside = outside[np.isfinite(outside)]
    assert np.all(prior.logpdf(outside) == -np.inf)


@pytest.mark.parametrize(("family", "params", "cut"), CASES)
def test_array_and_single_points_agree(family, params, cut):
    """The all-inside fast path, the substituting path and one point at a time agree."""
    prior, ref, lo, hi = _build(family, params, cut)
    x = _grid(ref, lo, hi)[::5]
    mixed = np.concatenate([x, [lo - 1.0, hi + 1.0, np.nan]])
    batch = prior.logpdf(mixed)
    one_by_one = np.array([float(prior.logpdf(v)) for v in mixed])
    np.testing.assert_array_equal(batch[:-1], one_by_one[:-1])
    np.testing.assert_array_equal(batch[: x.size], prior.logpdf(x))
    assert np.all(batch[x.size:] == -np.inf)  # a NaN is outside every support
    u = np.linspace(0, 1, 9)
    # (a vectorised power may differ from the scalar one in the last place)
    np.testing.assert_allclose(prior.ppf(u), [float(prior.ppf(v)) for v in u], rtol=1e-15)
    assert prior.ppf(u.reshape(3, 3)).shape == (3, 3)


@pytest.mark.parametrize(("family", "params", "cut"), CASES)
def test_cdf_and_quantile_kernels_equal_scipy(family, params, cut):
    prior, ref, _, _ = _build(family, params, cut)
    x = _grid(ref, *ref.support())
    np.testing.assert_allclose(prior.cdf(x, *prior.param_values), ref.cdf(x),
                               rtol=1e-9, atol=1e-12)
    q = np.linspace(0.001, 0.999, 37)
    np.testing.assert_allclose(prior.quantile(q, *prior.param_values), ref.ppf(q),
                               rtol=1e-9, atol=1e-12)
    lo_nat, hi_nat = ref.support()
    if math.isfinite(lo_nat):  # the CDF saturates outside the support
        assert prior.cdf(lo_nat - 1.0, *prior.param_values) == pytest.approx(0.0, abs=1e-15)
    if math.isfinite(hi_nat):
        assert prior.cdf(hi_nat + 1.0, *prior.param_values) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize(("family", "params", "cut"), CASES)
def test_ppf_is_the_truncated_quantile(family, params, cut):
    prior, ref, lo, hi = _build(family, params, cut)
    c_lo, c_hi = ref.cdf(lo), ref.cdf(hi)
    u = np.linspace(0.0, 1.0, 51)
    expected = np.clip(ref.ppf(c_lo + u * (c_hi - c_lo)), lo, hi)
    np.testing.assert_allclose(prior.ppf(u), expected, rtol=1e-9, atol=1e-12)
    assert prior.ppf(0.0) == pytest.approx(lo, abs=1e-12)
    if math.isfinite(hi):
        assert prior.ppf(1.0) == pytest.approx(hi, rel=1e-9)
    assert prior.median() == pytest.approx(ref.ppf(0.5 * (c_lo + c_hi)), rel=1e-9)
    # and it inverts the truncated CDF
    x = prior.ppf(u[1:-1])
    np.testing.assert_allclose((ref.cdf(x) - c_lo) / (c_hi - c_lo), u[1:-1], atol=1e-9)


@pytest.mark.parametrize(("family", "params", "cut"), CASES)
def test_density_integrates_to_one(family, params, cut):
    prior = _build(family, params, cut)[0]
    # integrate over the prior's own quantile range: the ends hold a negligible mass
    a, b = float(prior.ppf(1e-12)), float(prior.ppf(1 - 1e-12))
    points = [float(prior.ppf(q)) for q in (0.01, 0.5, 0.99)]
    total, err = integrate.quad(lambda v: math.exp(float(prior.logpdf(v))), a, b,
                                points=points, limit=200)
    assert total == pytest.approx(1.0, abs=1e-6 + 2 * err)


@pytest.mark.parametrize(("family", "params", "cut"), CASES)
def test_samples_follow_the_truncated_law(family, params, cut):
    prior, ref, lo, hi = _build(family, params, cut)
    draws = prior.sample(np.random.default_rng(11), 4000)
    assert draws.shape == (4000,)
    assert np.all((draws >= lo) & (draws <= hi))
    c_lo, c_hi = ref.cdf(lo), ref.cdf(hi)
    result = stats.kstest(draws, lambda v: (ref.cdf(v) - c_lo) / (c_hi - c_lo))
    assert result.pvalue > 1e-3
    assert prior.sample(np.random.default_rng(3), (2, 5)).shape == (2, 5)
    np.testing.assert_array_equal(prior.sample(np.random.default_rng(3), 7),
                                  prior.sample(np.random.default_rng(3), 7))


@pytest.mark.parametrize(("family", "params", "cut"), CASES)
@pytest.mark.parametrize("factor", [1e-3, 7.0])
def test_scaled_is_the_law_of_the_scaled_variable(family, params, cut, factor):
    prior, ref, lo, hi = _build(family, params, cut)
    big = prior.scaled(factor)
    assert type(big) is type(prior)
    assert big.support == pytest.approx((lo * factor, hi * factor))
    x = _grid(ref, lo, hi)
    np.testing.assert_allclose(big.logpdf(factor * x), prior.logpdf(x) - math.log(factor),
                               rtol=1e-9, atol=1e-9)
    u = np.linspace(0, 1, 11)
    np.testing.assert_allclose(big.ppf(u), factor * prior.ppf(u), rtol=1e-9, atol=1e-300)
    for bad in (0.0, -2.0, float("nan")):
        with pytest.raises(ValueError, match="positive"):
            prior.scaled(bad)


@pytest.mark.parametrize(("family", "params", "cut"), CASES)
def test_describe_names_the_family_and_its_parameters(family, params, cut):
    prior, _, _, _ = _build(family, params, cut)
    text = prior.describe()
    assert text.startswith(f"{family}(")
    for name in FAMILIES[family][1]:
        assert f"{name}=" in text


@pytest.mark.parametrize(("lower", "upper"), [(128.0, 135.0), (-np.inf, 130.0), (133.0, 150.0)])
def test_truncated_normal_equals_scipy_truncnorm(lower, upper):
    prior = Normal(mu=131.0, sigma=2.0, lower=lower, upper=upper)
    ref = stats.truncnorm((lower - 131.0) / 2.0, (upper - 131.0) / 2.0, loc=131.0, scale=2.0)
    x = np.linspace(max(lower, 120.0), min(upper, 142.0), 31)[1:-1]
    np.testing.assert_allclose(prior.logpdf(x), ref.logpdf(x), rtol=1e-9)
    u = np.linspace(0.01, 0.99, 21)
    np.testing.assert_allclose(prior.ppf(u), ref.ppf(u), rtol=1e-9)


def test_natural_support_limits_the_truncation():
    """A half-normal or a log-normal asked for negative values still starts at 0."""
    for family in ("halfnormal", "lognormal"):
        params = REFERENCE[family][0][0]
        prior = FAMILIES[family][0](**params, lower=-5.0)
        assert prior.support[0] == 0.0
        assert prior.mass == pytest.approx(1.0)
    wide = FAMILIES["uniform"][0](low=1.0, high=2.0, lower=0.0, upper=9.0)
    assert wide.support == (1.0, 2.0)
    assert wide.truncated(1.5, 9.0).support == (1.5, 2.0)
    assert wide.truncated(1.5, 9.0).logpdf(1.75) == pytest.approx(math.log(2.0))


def test_fixed_value():
    fixed = Fixed(0.131)
    assert fixed.is_fixed and not Normal().is_fixed
    assert fixed.support == (0.131, 0.131)
    np.testing.assert_array_equal(fixed.logpdf([0.131, 0.13, np.nan]), [0.0, -np.inf, -np.inf])
    np.testing.assert_array_equal(fixed.ppf(np.linspace(0, 1, 4)), np.full(4, 0.131))
    assert np.all(fixed.sample(np.random.default_rng(0), 5) == 0.131)
    assert fixed.median() == 0.131
    assert fixed.scaled(1e3).value == pytest.approx(131.0)
    assert "fixed" in fixed.describe()


# --- bad parameters, through the config reader -------------------------------------------

JITTER = QUANTITIES["jitter_ms"]


@pytest.mark.parametrize(("value", "message"), [
    ({"dist": "normal", "mu": 1.0, "sigma": 0.0}, r"priors.jitter_ms.sigma: must be positive"),
    ({"dist": "halfnormal", "sigma": -1.0}, r"sigma: must be positive"),
    ({"dist": "lognormal", "mu": 0.0, "sigma": -0.1}, r"sigma: must be positive"),
    ({"dist": "beta", "a": 0.0, "b": 2.0}, r"priors.jitter_ms.a: must be positive"),
    ({"dist": "beta", "a": 2.0, "b": -1.0}, r"\.b: must be positive"),
    ({"dist": "uniform", "low": 2.0, "high": 1.0}, r"range is inverted"),
    ({"dist": "uniform", "low": 1.0, "high": 1.0}, r"range is empty"),
    ({"dist": "loguniform", "low": 0.0, "high": 1.0}, r"loguniform range must start above 0"),
    ({"dist": "uniform", "low": -1.0, "high": 1.0}, r"goes outside the physical range"),
    ({"dist": "normal", "mu": -50.0, "sigma": 1.0}, r"centred at"),
    ({"dist": "normal", "mu": 1.0}, r"the normal distribution needs 'sigma'"),
    ({"dist": "cauchy", "mu": 1.0}, r"unknown value 'cauchy'"),
    ({"dist": "normal", "mu": 1.0, "sigma": 1.0, "scale": 2.0}, r"unknown key"),
    ({"mu": 1.0, "sigma": 1.0}, r"needs 'dist'"),
    ({"dist": "normal", "mu": "one", "sigma": 1.0}, r"expected a number"),
    (-3.0, r"outside the physical range"),
])
def test_bad_parameters_raise_config_errors(value, message):
    with pytest.raises(ConfigError, match=message):
        parse_prior(value, JITTER, "priors.jitter_ms")


#: A prior of the jitter (in ms) of each family, inside its physical range (> 0).
JITTER_PRIORS = {"uniform": {"low": 0.01, "high": 10.0}, "loguniform": {"low": 0.01, "high": 10.0},
                 "normal": {"mu": 3.0, "sigma": 2.0}, "halfnormal": {"sigma": 1.0},
                 "lognormal": {"mu": 0.0, "sigma": 1.0},
                 "beta": {"a": 2.0, "b": 5.0, "low": 0.5, "high": 4.0}}


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_parsed_prior_is_the_family_in_si_units(family):
    """A prior written in milliseconds is the same family, truncated to the physical range
    (jitter > 0) and scaled to seconds."""
    params = JITTER_PRIORS[family]
    prior = parse_prior({"dist": family, **params}, JITTER, "priors.jitter_ms")
    assert isinstance(prior, FAMILIES[family][0])
    ref = REFERENCE[family][1](params)
    lo, hi = max(0.0, float(ref.support()[0])), float(ref.support()[1])
    mass = ref.cdf(hi) - ref.cdf(lo)
    x_ms = _grid(ref, lo, hi)
    np.testing.assert_allclose(prior.logpdf(1e-3 * x_ms),
                               ref.logpdf(x_ms) - math.log(mass) - math.log(1e-3), rtol=1e-9)
    assert prior.support == pytest.approx((1e-3 * lo, 1e-3 * hi))


@pytest.mark.parametrize("prior", [HalfNormal(sigma=0.02), Normal(mu=0.0, sigma=1.0)])
def test_density_far_out_is_minus_infinity_without_a_warning(prior):
    """A scale sampled in its logarithm reaches 1e200 on a long jump (a RuntimeWarning in a
    coverage run of the restitution scatter); its density is −inf, silently."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert prior.logpdf(np.array([1e200]))[0] == -np.inf


# --- an atom at 0 (an effect that may be absent) -----------------------------------------

CONTACT = QUANTITIES["contact_ms"]


@pytest.mark.parametrize(("slab", "p_zero"), [({"dist": "uniform", "low": 0.0, "high": 3.0}, 0.5),
                                              ({"dist": "halfnormal", "sigma": 1.0}, 0.2)])
def test_an_atom_at_zero_is_the_mixture_it_describes(slab, p_zero):
    """``p_zero`` in a contact-time prior: the coordinate's density integrates to 1, its
    negative half holds p_zero, the parameter (max(u, 0)) is 0 with probability p_zero and
    otherwise follows scipy's slab, in seconds; half and double widen only the slab."""
    prior = parse_prior({**slab, "p_zero": p_zero}, CONTACT, "priors.contact_ms")
    assert isinstance(prior, OrZero)
    lo, hi = prior.support
    top = hi if math.isfinite(hi) else 0.02
    total = (integrate.quad(lambda u: float(np.exp(prior.logpdf(u))), lo, 0.0)[0]
             + integrate.quad(lambda u: float(np.exp(prior.logpdf(u))), 0.0, top)[0])
    assert total == pytest.approx(1.0, abs=1e-6)
    assert prior.logpdf(lo - 1e-6) == -np.inf and prior.logpdf(-1e-4) == math.log(p_zero / -lo)
    ref = (stats.uniform(0.0, 3e-3) if slab["dist"] == "uniform" else stats.halfnorm(scale=1e-3))
    u = prior.sample(np.random.default_rng(3), 20_000)
    value = prior.parameter_of(u)
    assert np.mean(value == 0.0) == pytest.approx(p_zero, abs=0.015)
    assert stats.kstest(value[value > 0.0], ref.cdf).pvalue > 1e-3
    np.testing.assert_allclose(prior.ppf(np.array([0.0, p_zero, 1.0 - 1e-12])),
                               [lo, 0.0, ref.ppf(1.0 - 1e-12 / (1.0 - p_zero))], rtol=1e-6)
    wider = prior.widened(2.0)
    assert wider.p_zero == p_zero and wider.slab == prior.slab.widened(2.0)
    assert "or 0 with probability" in prior.describe()


@pytest.mark.parametrize(("value", "message"), [
    ({"dist": "uniform", "low": 0.0, "high": 3.0, "p_zero": 1.0}, r"strictly between 0 and 1"),
    ({"dist": "uniform", "low": 0.0, "high": 3.0, "p_zero": 0.0}, r"give the number 0"),
    ({"dist": "uniform", "low": 0.5, "high": 3.0, "p_zero": 0.5}, r"needs a distribution "
                                                                   r"that starts at 0"),
])
def test_bad_atoms_at_zero_raise_config_errors(value, message):
    with pytest.raises(ConfigError, match=message):
        parse_prior(value, CONTACT, "priors.contact_ms")


def test_only_an_effect_that_may_be_absent_takes_an_atom_at_zero():
    with pytest.raises(ConfigError, match=r"unknown key"):
        parse_prior({"dist": "halfnormal", "sigma": 1.0, "p_zero": 0.5}, JITTER,
                    "priors.jitter_ms")
