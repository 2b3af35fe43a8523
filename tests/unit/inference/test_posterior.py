"""The samplers' lean paths equal the general ones (full forward model, per-column priors).

``LogPosterior.__call__`` / ``log_likelihood`` / ``log_likelihood_one`` and
``ParameterSpace.log_prior`` / ``prior_transform`` are written for speed; here they are checked
against the reference implementations on random prior draws, on draws pushed outside the prior
or the physics, and on special values, for every model and several set-ups.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

from drumroll.config import parse_config
from drumroll.inference.likelihood import OnsetData
from drumroll.inference.posterior import LogPosterior
from drumroll.physics import StickGeometry, bounce_sequence

BASE = {
    "model": "pendulum",
    "stick": {"shape": "cylinder-cone", "length_mm": {"dist": "normal", "mu": 348, "sigma": 1},
              "tip_mm": {"dist": "normal", "mu": 60, "sigma": 1}, "radius_mm": 7.5},
    "priors": {"alpha": {"dist": "uniform", "low": 0.5, "high": 1.0},
               "pivot_mm": {"dist": "normal", "mu": 131, "sigma": 2},
               "height_mm": {"dist": "normal", "mu": 80, "sigma": 3},
               "release_speed_m_s": 0, "release_angle_deg": 0,
               "jitter_ms": {"dist": "loguniform", "low": 0.01, "high": 10},
               "t_b": {"dist": "uniform", "low": 0.01, "high": 2.0},
               # used by the MOTION/speed models only
               "restitution_exponent": {"dist": "normal", "mu": 0.2, "sigma": 0.3}},
}


def _config(variant: str):
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in BASE.items()}
    priors, stick = raw["priors"], raw["stick"]
    if variant == "release":  # sampled release speed and angle, wide height and pivot
        priors["release_speed_m_s"] = {"dist": "halfnormal", "sigma": 0.5}
        priors["release_angle_deg"] = {"dist": "normal", "mu": 0, "sigma": 10}
        priors["height_mm"] = {"dist": "uniform", "low": 10, "high": 300}
        priors["pivot_mm"] = {"dist": "lognormal", "mu": math.log(131), "sigma": 0.3}
    elif variant == "thin-rod":
        raw["stick"] = {"shape": "thin-rod", "length_mm": {"dist": "normal", "mu": 408,
                                                          "sigma": 2}}
        priors["alpha"] = {"dist": "beta", "a": 20, "b": 3}
    elif variant == "scatter":  # the restitution's scatter, sampled in its logarithm
        priors["restitution_scatter"] = {"dist": "halfnormal", "sigma": 0.02}
    elif variant == "scatter-atom":  # a scatter that may be absent: an atom, not a logarithm
        priors["restitution_scatter"] = {"dist": "halfnormal", "sigma": 0.02, "p_zero": 0.3}
    elif variant == "radius":
        stick["radius_mm"] = {"dist": "uniform", "low": 5, "high": 10}
        priors["jitter_ms"] = {"dist": "halfnormal", "sigma": 1.0}
    return parse_config(raw)


def _data(sigmas: bool) -> OnsetData:
    stick = StickGeometry("cylinder-cone", 0.348, 0.06, 0.0075)
    b = bounce_sequence("pendulum", alpha=0.88, pivot=0.131, height=0.08, stick=stick,
                        n_flights=25)
    rng = np.random.default_rng(0)
    times = 1.234 + b.impacts[0] + rng.normal(0, 1e-4, 26)
    return OnsetData.from_arrays(times, rng.uniform(0, 3e-4, 26) if sigmas else None)


def _points(lp: LogPosterior, rng: np.random.Generator) -> np.ndarray:
    """Prior draws, draws from a cube 40 % wider than the prior's (many invalid), and junk."""
    space = lp.space
    inside = space.sample_prior(rng, 300)
    wide = space.prior_transform_by_column(np.full((300, space.ndim), 0.5))
    spread = np.std(inside, axis=0)
    wide = wide + spread * rng.normal(0, 30, (300, space.ndim))
    junk = inside[:6].copy()
    junk[0, 0] = np.nan
    junk[1, 0] = 1.2  # alpha > 1
    junk[2, 0] = 1.0  # alpha == 1: valid unless it goes over the top
    junk[3] = np.inf
    junk[4, -1] = -1.0
    return np.concatenate([inside, wide, junk])


CASES = [(model, variant, sigmas, noise)
         for model in ("pendulum", "small-angle", "powerlaw")
         for variant, sigmas, noise in (("table1", False, "gaussian"),
                                        ("release", True, "gaussian"),
                                        ("thin-rod", False, "gaussian"),
                                        ("radius", True, "student-t"))]


@pytest.mark.parametrize(("model", "variant", "sigmas", "noise"), CASES)
def test_lean_log_posterior_equals_reference(model, variant, sigmas, noise):
    """Batch and one-point paths agree with the general path to 1e-11, −inf included (prior
    draws far from the data have χ² ~ 1e10, whose last digits depend on summation order)."""
    lp = LogPosterior.build(_config(variant), model, _data(sigmas), noise)
    # A stable seed per case (hash() of a str changes with every interpreter run).
    rng = np.random.default_rng(zlib.crc32(f"{model}/{variant}".encode()))
    x = _points(lp, rng)
    want = lp.reference(x)
    with np.errstate(all="raise"):  # the lean paths never warn
        got = lp(x)
        one = np.array([lp(row) for row in x])
        like_one = np.array([lp.log_likelihood_one(row) for row in x])
    finite = np.isfinite(want)
    assert finite.sum() > 150 and (~finite).sum() > 30  # both kinds are exercised
    for value in (got, one):
        np.testing.assert_array_equal(np.isfinite(value), finite)
        np.testing.assert_allclose(value[finite], want[finite], rtol=1e-11, atol=1e-9)
        assert np.all(value[~finite] == -np.inf)
    like = lp.log_likelihood_reference(x[finite])
    np.testing.assert_allclose(lp.log_likelihood(x[finite]), like, rtol=1e-11, atol=1e-9)
    np.testing.assert_allclose(like_one[finite], like, rtol=1e-11, atol=1e-9)


@pytest.mark.parametrize("variant", ["table1", "release", "thin-rod", "radius"])
@pytest.mark.parametrize("model", ["pendulum", "powerlaw"])
def test_prior_table_equals_per_column_priors(model, variant):
    lp = LogPosterior.build(_config(variant), model, _data(False))
    space, rng = lp.space, np.random.default_rng(3)
    u = rng.random((500, space.ndim))
    u[:5] = [0.0, 1.0, 0.5, 1e-12, 1 - 1e-12][:5] if space.ndim == 1 else u[:5]
    u[0], u[1] = 0.0, 1.0
    np.testing.assert_allclose(space.prior_transform(u), space.prior_transform_by_column(u),
                               rtol=1e-13, atol=0)
    np.testing.assert_allclose(space.prior_transform(u[7]),
                               space.prior_transform_by_column(u[7]), rtol=1e-13)
    x = _points(lp, rng)
    want = space.log_prior_by_column(x)
    got = space.log_prior(x)
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(want))
    finite = np.isfinite(want)
    np.testing.assert_allclose(got[finite], want[finite], rtol=1e-12, atol=1e-12)


def test_lean_impacts_match_bounces_on_valid_points():
    lp = LogPosterior.build(_config("release"), "pendulum", _data(False))
    x = lp.space.sample_prior(np.random.default_rng(5), 400)
    bounces = lp.space.bounces(x, 25)
    # The full forward model's impacts, each delayed by the contacts before it (sampled by
    # default).
    assert "contact" in lp.space.names
    expected = lp.space.impact_times(lp.space.values(x), 25)
    impacts, valid = lp.space.impacts(x, 25)
    np.testing.assert_array_equal(valid, bounces.valid)
    assert valid.sum() > 100
    np.testing.assert_allclose(impacts[valid], expected[valid], rtol=1e-13, atol=1e-15)
    for row in np.flatnonzero(valid)[:50]:
        np.testing.assert_allclose(lp.space.impacts_one(x[row], 25), expected[row],
                                   rtol=1e-13, atol=1e-15)
    for row in np.flatnonzero(~valid)[:50]:
        assert lp.space.impacts_one(x[row], 25) is None


# --- sampler coordinates ---------------------------------------------------------------------

from drumroll.inference.coordinates import AtomGeometry, SamplerCoordinates  # noqa: E402
from drumroll.inference.sampling import SamplerSettings, SamplerTarget, run_emcee  # noqa: E402

COORDINATE_CASES = [(model, variant) for model in ("pendulum", "small-angle", "powerlaw")
                    for variant in ("table1", "release", "thin-rod", "scatter", "scatter-atom")]


def _numerical_log_det(coords, zr: np.ndarray) -> float:
    """log |det ∂x/∂z| at one point by central differences."""
    step = 1e-6 * np.maximum(np.abs(zr), 1e-3)
    jac = np.empty((zr.size, zr.size))
    for j in range(zr.size):
        hi, lo = zr.copy(), zr.copy()
        hi[j] += step[j]
        lo[j] -= step[j]
        jac[:, j] = (coords.to_parameters(hi)[0][0] - coords.to_parameters(lo)[0][0]) \
            / (2 * step[j])
    return float(np.log(abs(np.linalg.det(jac))))


@pytest.mark.parametrize("fold", [False, True], ids=["log-scatter", "folded-scatter"])
@pytest.mark.parametrize(("model", "variant"), COORDINATE_CASES)
def test_sampler_coordinates_round_trip_and_jacobian(model, variant, fold):
    """z → x inverts x → z on valid points, and log|det| matches a finite-difference Jacobian
    (the scatter through its logarithm, or as the absolute value of its column, as the
    ensemble walks it)."""
    lp = LogPosterior.build(_config(variant), model, _data(False))
    coords = SamplerCoordinates(lp.space, fold_scatter=fold)
    if fold and variant == "scatter":
        assert coords.folded_columns == (lp.space.names.index("restitution_scatter"),)
    else:
        assert coords.folded_columns == ()
    x = lp.space.sample_prior(np.random.default_rng(7), 400)
    x = x[np.isfinite(lp(x))][:60]
    assert len(x) >= 20
    z = coords.to_sampler(x)
    back, log_det = coords.to_parameters(z)
    np.testing.assert_allclose(back, x, rtol=1e-11, atol=0)
    for row, zr in enumerate(z[:20]):
        np.testing.assert_allclose(log_det[row], _numerical_log_det(coords, zr), atol=1e-6)


def test_a_folded_scatter_column_is_its_absolute_value():
    """With ``fold_scatter`` the scatter's column maps to |z|, both signs alike, with unit
    Jacobian, in the batch and the one-point maps; every other column is as without it."""
    lp = LogPosterior.build(_config("scatter"), "pendulum", _data(False))
    plain, folded = SamplerCoordinates(lp.space), SamplerCoordinates(lp.space, fold_scatter=True)
    j = lp.space.names.index("restitution_scatter")
    x = lp.space.sample_prior(np.random.default_rng(5), 200)
    x = x[np.isfinite(lp(x))][:10]
    z = folded.to_sampler(x)
    np.testing.assert_allclose(z[:, j], x[:, j])
    mirrored = z.copy()
    mirrored[:, j] = -z[:, j]
    for zz in (z, mirrored):
        back, log_det = folded.to_parameters(zz)
        np.testing.assert_allclose(back, x, rtol=1e-11)
        np.testing.assert_allclose(log_det, plain.to_parameters(plain.to_sampler(x))[1]
                                   - np.log(x[:, j]), rtol=1e-11)
        for row in range(len(zz)):
            one = folded.to_parameters_one(zz[row])
            np.testing.assert_allclose(one[0], back[row], rtol=1e-12)
            assert one[1] == pytest.approx(log_det[row], abs=1e-9)


def _atom_geometry(lp: LogPosterior, coords: SamplerCoordinates, rng: np.random.Generator
                   ) -> tuple[AtomGeometry, ...]:
    """A plateau narrower than the prior's and a ridge of random slopes, per atom column."""
    out = []
    for j in coords.atom_columns:
        width = lp.space.priors[lp.space.names[j]].width
        ridge = rng.normal(0.0, 0.3, lp.space.ndim) / width
        ridge[list(coords.atom_columns)] = 0.0
        out.append(AtomGeometry(width * 0.01, tuple(ridge)))
    return tuple(out)


@pytest.mark.parametrize(("model", "variant", "noise"),
                         [("pendulum", "release", "gaussian"), ("powerlaw", "table1", "student-t"),
                          ("small-angle", "scatter-atom", "gaussian")])
def test_sampler_coordinates_with_an_atom_s_geometry(model, variant, noise):
    """Effects that may be absent (the default contact time, a scatter with p_zero) under a
    geometry that scales their plateau and shears the other columns along a ridge: z → x
    inverts x → z, "absent" stays absent (x below 0) and "present" present, log|det| matches
    a finite-difference Jacobian, the one-point map equals the batch map, and the density of
    x is unchanged (the target less log|det| is the posterior)."""
    lp = LogPosterior.build(_config(variant), model, _data(noise != "gaussian"), noise=noise)
    plain = SamplerCoordinates(lp.space, lp.data)
    assert plain.atom_columns  # the default contact time, at least
    coords = SamplerCoordinates(lp.space, lp.data, _atom_geometry(lp, plain,
                                                                  np.random.default_rng(3)))
    x = lp.space.sample_prior(np.random.default_rng(7), 400)
    x = x[np.isfinite(lp(x))][:40]
    assert len(x) >= 20
    z = coords.to_sampler(x)
    for j in coords.atom_columns:
        np.testing.assert_array_equal(z[:, j] < 0, x[:, j] < 0)
        assert np.any(x[:, j] < 0) and np.any(x[:, j] > 0)
    back, log_det = coords.to_parameters(z)
    np.testing.assert_allclose(back, x, rtol=1e-9, atol=1e-12)
    for row, zr in enumerate(z[:15]):
        np.testing.assert_allclose(log_det[row], _numerical_log_det(coords, zr), atol=1e-5)
        one = coords.to_parameters_one(zr)
        np.testing.assert_allclose(one[0], back[row], rtol=1e-12, atol=1e-15)
        assert one[1] == pytest.approx(log_det[row], abs=1e-9)
    np.testing.assert_allclose(SamplerTarget(lp, coords)(z) - log_det, lp(back), rtol=1e-12)
    np.testing.assert_allclose(lp(back), lp(x), rtol=1e-9)


@pytest.mark.parametrize("model", ["pendulum", "small-angle"])
def test_sampler_coordinates_carry_the_height_prior_exactly(model):
    """∫ p(h(q)) |dh/dq| dq over the valid q equals the prior mass of the reachable heights."""
    lp = LogPosterior.build(_config("release"), model, _data(False))
    space, coords = lp.space, SamplerCoordinates(lp.space)
    ih = space.names.index("height")
    x0 = space.sample_prior(np.random.default_rng(11), 50)
    x0 = x0[np.isfinite(lp(x0))][0]
    heights = np.linspace(1e-7, 0.5, 200_001)
    xs = np.repeat(x0[None], heights.size, axis=0)
    xs[:, ih] = heights
    valid = space.impacts(xs, 0)[1]  # the physics' own validity (reach, contact angle)
    density_h = np.exp(space.priors["height"].logpdf(heights)) * valid
    mass_h = np.trapezoid(density_h, heights)
    q = coords.to_sampler(xs[valid])[:, ih]
    qs = np.linspace(q.min(), q.max(), 200_001)
    zs = np.repeat(coords.to_sampler(x0[None]), qs.size, axis=0)
    zs[:, ih] = qs
    xq, log_det = coords.to_parameters(zs)
    log_det -= zs[:, space.names.index("jitter")]  # the jitter's own term, constant here
    density_q = np.where(np.isfinite(xq[:, ih]),
                         np.exp(space.priors["height"].logpdf(np.nan_to_num(xq[:, ih]))
                                + log_det), 0.0)
    mass_q = np.trapezoid(density_q, qs)
    assert mass_h > 0.01
    np.testing.assert_allclose(mass_q, mass_h, rtol=2e-4)


def test_sampler_target_is_posterior_plus_log_det():
    lp = LogPosterior.build(_config("table1"), "pendulum", _data(False))
    coords = SamplerCoordinates(lp.space)
    x = lp.space.sample_prior(np.random.default_rng(2), 200)
    z = coords.to_sampler(x)
    target = SamplerTarget(lp, coords)(z)
    x_back, log_det = coords.to_parameters(z)
    want = lp(x_back) + log_det
    finite = np.isfinite(lp(x))
    np.testing.assert_allclose(target[finite], want[finite], rtol=1e-12)
    assert np.all(target[~finite] == -np.inf)


def test_run_emcee_reports_parameters_not_sampler_coordinates():
    """Samples are parameters and log_prob is their log posterior (the powerlaw: < 2 s)."""
    lp = LogPosterior.build(_config("table1"), "powerlaw", _data(False))
    chain = run_emcee(lp, SamplerSettings(walkers=16, seed=1))
    assert chain.converged
    flat = chain.samples.reshape(-1, lp.space.ndim)
    np.testing.assert_allclose(chain.log_prob.ravel(), lp(flat), rtol=1e-10)
    jitter = flat[:, lp.space.names.index("jitter")]
    assert 1e-4 < np.median(jitter) < 1e-2  # seconds (the misfit of a power law), not a log


@pytest.mark.parametrize("model", ["pendulum", "small-angle", "powerlaw"])
def test_sampler_coordinates_of_a_sampled_t0(model):
    """Student-t noise: T0 ↔ its non-centred offset round-trips, and log|det| (which now
    depends on the jitter and every flight) matches a finite-difference Jacobian."""
    lp = LogPosterior.build(_config("release"), model, _data(True), noise="student-t")
    coords = SamplerCoordinates(lp.space, lp.data)
    assert "t0" in lp.space.names
    rng = np.random.default_rng(5)
    x = lp.space.sample_prior(rng, 400)
    x = x[np.isfinite(lp(x))][:20]
    assert len(x) >= 10
    z = coords.to_sampler(x)
    back, log_det = coords.to_parameters(z)
    np.testing.assert_allclose(back, x, rtol=1e-10, atol=1e-12)
    for row, zr in enumerate(z):
        np.testing.assert_allclose(log_det[row], _numerical_log_det(coords, zr), atol=1e-5)
    target = SamplerTarget(lp, coords)(z)
    np.testing.assert_allclose(target, lp(x) + log_det, rtol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["gaussian", "student-t"])
def test_sampler_coordinates_leave_the_posterior_unchanged(noise):
    """Plain DE in x and DE in z give the same posterior moments (pendulum, within MC error);
    under Student-t noise z includes T0's non-centred offset.

    Both are compared given that the roll has no contact time (its atom at 0, the plateau of
    negative values in x, 97–98 % of the draws here): plain DE in x hardly ever moves a walker
    between "no contact" and "a contact", which shift α and the geometry along a ridge that
    only z straightens, so a walker started with a contact (2–3 % of the draws) stayed there,
    alone, for the whole run (acceptance 0.0003), and doubled α's sd."""
    import emcee

    lp = LogPosterior.build(_config("table1"), "pendulum", _data(False), noise=noise)
    chain = run_emcee(lp, SamplerSettings(seed=3))
    z_samples = chain.samples.reshape(-1, lp.space.ndim)
    z_samples = z_samples[z_samples[:, lp.space.names.index("contact")] <= 0.0]
    sampler = emcee.EnsembleSampler(32, lp.space.ndim, lp, vectorize=True,
                                    moves=[(emcee.moves.DEMove(), 1.0)])
    sampler._random.seed(4)
    start = z_samples[np.random.default_rng(4).choice(len(z_samples), 32, replace=False)]
    sampler.run_mcmc(start, 12_000)
    plain = sampler.get_chain(discard=1000).reshape(-1, lp.space.ndim)
    tau = sampler.get_autocorr_time(tol=0).max()
    n_eff = min(len(plain) / tau, len(z_samples) / np.max(chain.tau))
    sd = plain.std(axis=0)
    assert np.all(np.abs(z_samples.mean(axis=0) - plain.mean(axis=0)) < 5 * sd / np.sqrt(n_eff))
    assert np.all(np.abs(z_samples.std(axis=0) / sd - 1) < 5 / np.sqrt(n_eff))


@pytest.mark.parametrize(("model", "variant", "noise"),
                         [(m, v, n) for m, v in COORDINATE_CASES
                          for n in ("gaussian", "student-t")])
def test_one_point_coordinates_equal_the_batch_map(model, variant, noise):
    """Nested sampling's one-point z → x map equals the batch map, including points the
    batch map sends to NaN (None) and a sampled T0's offset."""
    lp = LogPosterior.build(_config(variant), model, _data(True), noise=noise)
    coords = SamplerCoordinates(lp.space, lp.data)
    rng = np.random.default_rng(9)
    x = lp.space.sample_prior(rng, 300)
    x = x[np.isfinite(lp(x))][:40]
    z = coords.to_sampler(x)
    z = np.concatenate([z, z[:20] * rng.uniform(0.5, 1.5, z[:20].shape)])  # some invalid
    batch_x, batch_log_det = coords.to_parameters(z)
    valid = np.isfinite(lp(batch_x))
    assert 20 <= valid.sum() < len(z)
    for row, ok in zip(range(len(z)), valid, strict=True):
        one = coords.to_parameters_one(z[row])
        if not ok:
            assert one is None or not np.isfinite(lp(one[0][None]))[0]
            continue
        assert one is not None
        np.testing.assert_allclose(one[0], batch_x[row], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(one[1], batch_log_det[row], rtol=1e-12, atol=1e-12)
        if one[2] is not None:
            np.testing.assert_allclose(one[2], lp.space.impacts(batch_x[row:row + 1],
                                                                lp.data.n_flights)[0][0])


@pytest.mark.parametrize(("model", "variant"), [("pendulum", "release"),
                                              ("small-angle", "thin-rod"),
                                              ("powerlaw", "radius")])
def test_start_search_coordinates_put_t0_at_its_best_value(model, variant):
    """``to_sampler(x, t0_centred=True)`` (the start search's prior draws, mapped without a
    forward model) is ``to_sampler(x)`` with T0's offset δ set to 0, as the search had it: every
    other column the same, bit for bit, and the point maps back to x but for T0, which is
    the one whose offset is 0 (T0 is sampled under Student-t noise)."""
    lp = LogPosterior.build(_config(variant), model, _data(True), noise="student-t")
    coords = SamplerCoordinates(lp.space, lp.data)
    t0 = coords.t0_column
    assert t0 is not None
    x = lp.space.sample_prior(np.random.default_rng(11), 400)
    x = x[np.isfinite(lp(x))][:30]
    assert len(x) >= 10
    centred, plain = coords.to_sampler(x, t0_centred=True), coords.to_sampler(x)
    others = [j for j in range(lp.space.ndim) if j != t0]
    np.testing.assert_array_equal(centred[:, others], plain[:, others])
    np.testing.assert_array_equal(centred[:, t0], 0.0)
    best = coords.to_parameters(centred)[0]
    np.testing.assert_allclose(best[:, others], x[:, others], rtol=1e-11)
    np.testing.assert_allclose(coords.to_sampler(best)[:, t0], 0.0, atol=1e-9)
    assert np.all(np.abs(best[:, t0] - x[:, t0]) > 0)  # the prior's T0 was moved
