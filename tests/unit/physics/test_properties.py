"""Property tests (hypothesis) of the three forward models.

Every model call runs with warnings turned into errors (``quiet_call``): a forward model
evaluated inside a sampler must never warn, whatever the parameter point.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from drumroll.physics import REASONS, StickGeometry, bounce_sequence
from drumroll.physics.bounces import NOT_FINITE

G = 9.81
STICK = StickGeometry("cylinder-cone", length=0.348, tip=0.060, radius=0.0075)
L_TOTAL = 0.408
# Centre of mass: cylinder (mass ∝ l1, at l1/2) and cone (mass ∝ l2/3, at l1 + l2/4).
L_C = (0.348 * 0.174 + 0.020 * (0.348 + 0.015)) / (0.348 + 0.020)
N_FLIGHTS = 40

def quiet_call(*args, **kwargs):
    """bounce_sequence with every warning an error (hypothesis shrinks failures too)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return bounce_sequence(*args, **kwargs)


@st.composite
def drops(draw, alpha=None):
    """A physically valid drop for the geometric models (may still go over the top)."""
    pivot = draw(st.floats(0.0, 0.18))
    arm = L_TOTAL - pivot
    height = draw(st.floats(0.001, 0.95)) * arm
    theta_c_linear = height / arm  # ≤ arcsin: a release angle below it suits both models
    angle = draw(st.floats(-1.5, 0.95 * theta_c_linear))
    speed = draw(st.floats(0.0, 4.0))
    if alpha is None:
        alpha = draw(st.floats(0.05, 0.999))
    return {"alpha": alpha, "pivot": pivot, "height": height, "release_angle": angle,
            "release_speed": speed, "stick": STICK}


# --------------------------------------------------------------------------------------------
# Physics of the sequences
# --------------------------------------------------------------------------------------------
@given(drops())
def test_flights_strictly_decrease_geometric_models(drop):
    """0 < α < 1: each flight is shorter than the one before (small-angle and pendulum)."""
    for model in ("small-angle", "pendulum"):
        result = quiet_call(model, n_flights=N_FLIGHTS, **drop)
        if model == "pendulum" and not result.valid[0]:
            assert result.reasons() == [REASONS[8]]  # the only way a valid drop can fail
            continue
        assert result.valid[0]
        flights = result.flights[0]
        assert np.all(flights > 0)
        assert np.all(np.diff(flights) < 0)
        assert result.t_c[0] > 0


@given(st.floats(0.01, 0.999), st.floats(1e-3, 10.0))
def test_flights_strictly_decrease_powerlaw(alpha, t_b):
    """Power law: T_k = t_B α^k decreases strictly for 0 < α < 1."""
    result = quiet_call("powerlaw", alpha=alpha, t_b=t_b, n_flights=N_FLIGHTS)
    assert result.valid[0]
    assert np.all(np.diff(result.flights[0]) < 0)


@given(st.floats(0.05, 1.0), st.floats(1e-3, 10.0), st.floats(0.01, 100.0))
def test_powerlaw_scales_linearly_with_t_b(alpha, t_b, factor):
    """Multiplying t_B multiplies every flight; and T_k / t_B = α^k."""
    one = quiet_call("powerlaw", alpha=alpha, t_b=t_b, n_flights=N_FLIGHTS)
    scaled = quiet_call("powerlaw", alpha=alpha, t_b=factor * t_b, n_flights=N_FLIGHTS)
    np.testing.assert_allclose(scaled.flights, factor * one.flights, rtol=1e-14)
    np.testing.assert_allclose(one.flights[0] / t_b, alpha ** np.arange(1, N_FLIGHTS + 1),
                               rtol=1e-13)


@given(drops())
def test_small_angle_flights_scale_linearly_with_t_b(drop):
    """Small-angle: T_k = t_B α^k whatever h, d and the release (only ω_C/γ matters)."""
    result = quiet_call("small-angle", n_flights=N_FLIGHTS, **drop)
    k = np.arange(1, N_FLIGHTS + 1)
    np.testing.assert_allclose(result.flights[0], result.t_b[0] * drop["alpha"] ** k,
                               rtol=1e-13)
    # Two drops with the same t_B have the same flights (same α): scale h, keep d.
    other = dict(drop, height=0.5 * drop["height"], release_angle=0.0, release_speed=0.0)
    twin = quiet_call("small-angle", n_flights=N_FLIGHTS, **other)
    np.testing.assert_allclose(twin.flights[0] / twin.t_b[0], result.flights[0] / result.t_b[0],
                               rtol=1e-13)


@given(drops(), st.data())
def test_impacts_and_impact_tip_speeds(drop, data):
    """impacts = [0, cumsum(flights)]; impact tip speed k = α^k × contact tip speed."""
    model = data.draw(st.sampled_from(["powerlaw", "small-angle", "pendulum"]))
    if model == "powerlaw":
        result = quiet_call(model, alpha=drop["alpha"], t_b=0.25, n_flights=N_FLIGHTS)
    else:
        result = quiet_call(model, n_flights=N_FLIGHTS, **drop)
    assume(result.valid[0])
    impacts = result.impacts[0]
    assert impacts.shape == (N_FLIGHTS + 1,)
    assert impacts[0] == 0.0
    np.testing.assert_allclose(np.diff(impacts), result.flights[0], rtol=0,
                               atol=1e-14 * impacts[-1])  # rounding of a running sum
    np.testing.assert_allclose(impacts[1:], np.cumsum(result.flights[0]), rtol=1e-15)
    k = np.arange(N_FLIGHTS + 1)
    speeds = result.impact_tip_speeds[0]
    expected = result.tip_speed_c[0] * drop["alpha"] ** k
    np.testing.assert_allclose(speeds, expected, rtol=1e-14, equal_nan=model == "powerlaw")
    if model != "powerlaw":
        arm = L_TOTAL - drop["pivot"]
        assert result.tip_speed_c[0] == pytest.approx(result.omega_c[0] * arm, rel=1e-14)


# --------------------------------------------------------------------------------------------
# Batches equal single evaluations
# --------------------------------------------------------------------------------------------
FIELDS = ("alpha", "flights", "t_c", "t_b", "theta_c", "omega_c", "tip_speed_c", "reason")


def assert_same(batch, i, single):
    """Element i of a batch equals a one-element evaluation (to 1e-15, NaN = NaN)."""
    for name in FIELDS:
        got, want = getattr(batch, name)[i], getattr(single, name)[0]
        np.testing.assert_allclose(got, want, rtol=1e-15, atol=0, equal_nan=True,
                                   err_msg=name)


@st.composite
def mixed_drops(draw):
    """Any drop: mostly valid, sometimes invalid in one way or another."""
    drop = draw(drops())
    spoil = draw(st.sampled_from(["none"] * 4 + ["alpha", "pivot", "height", "over", "nan"]))
    if spoil == "alpha":
        drop["alpha"] = draw(st.sampled_from([0.0, -0.3, 1.2, np.nan]))
    elif spoil == "pivot":
        drop["pivot"] = draw(st.floats(L_C, L_TOTAL - 0.01))
    elif spoil == "height":
        drop["height"] = L_TOTAL - drop["pivot"] + draw(st.floats(0.0, 0.2))
    elif spoil == "over":
        drop["alpha"], drop["release_speed"] = 0.999, 20.0
    elif spoil == "nan":
        drop[draw(st.sampled_from(["pivot", "height", "release_angle", "release_speed"]))] = \
            np.nan
    return drop


@given(st.lists(mixed_drops(), min_size=1, max_size=9),
       st.sampled_from(["small-angle", "pendulum"]))
def test_batch_equals_one_by_one_geometric(drop_list, model):
    """A batch of drops gives, element by element, what each drop gives on its own."""
    names = ("alpha", "pivot", "height", "release_angle", "release_speed")
    columns = {name: np.array([d[name] for d in drop_list]) for name in names}
    batch = quiet_call(model, n_flights=N_FLIGHTS, stick=STICK, **columns)
    assert batch.flights.shape == (len(drop_list), N_FLIGHTS)
    for i, drop in enumerate(drop_list):
        assert_same(batch, i, quiet_call(model, n_flights=N_FLIGHTS, **drop))


@given(st.lists(st.tuples(st.one_of(st.floats(0.01, 1.0), st.sampled_from([0.0, 1.5, np.nan])),
                          st.one_of(st.floats(1e-3, 10.0), st.sampled_from([0.0, -1.0]))),
                min_size=1, max_size=9))
def test_batch_equals_one_by_one_powerlaw(pairs):
    """The same for the power law, valid and invalid (α, t_B) mixed."""
    alpha, t_b = (np.array(col) for col in zip(*pairs, strict=True))
    batch = quiet_call("powerlaw", alpha=alpha, t_b=t_b, n_flights=N_FLIGHTS)
    for i in range(len(pairs)):
        assert_same(batch, i, quiet_call("powerlaw", alpha=alpha[i], t_b=t_b[i],
                                         n_flights=N_FLIGHTS))


def test_batch_broadcasts_scalars_against_arrays():
    """Scalar parameters broadcast against array ones (one geometry, many α)."""
    alpha = np.linspace(0.5, 0.95, 6)
    batch = quiet_call("pendulum", alpha=alpha, n_flights=5, pivot=0.131, height=0.08,
                       stick=STICK)
    assert batch.flights.shape == (6, 5)
    for i, a in enumerate(alpha):
        assert_same(batch, i, quiet_call("pendulum", alpha=a, n_flights=5, pivot=0.131,
                                         height=0.08, stick=STICK))


# --------------------------------------------------------------------------------------------
# Invalid points: valid == False, NaN flights, the right reason, and no exception or warning
# --------------------------------------------------------------------------------------------
def assert_invalid(result, reason_code):
    assert result.valid.tolist() == [False]
    assert result.reason.tolist() == [reason_code]
    assert result.reasons() == [REASONS[reason_code]]
    assert np.isnan(result.flights).all()
    assert np.isnan(result.t_c).all() and np.isnan(result.t_b).all()
    assert np.isnan(result.impacts[:, 1:]).all()
    assert np.isnan(result.impact_tip_speeds).all()


GEOMETRIC_NAMES = ["small-angle", "pendulum"]
GEOMETRIC = st.sampled_from(GEOMETRIC_NAMES)


@given(drops(), st.floats(0.0, 1.0), GEOMETRIC)
def test_pivot_past_centre_of_mass_is_invalid(drop, where, model):
    drop["pivot"] = L_C + where * (L_TOTAL - L_C - 0.02)
    drop["height"] = 0.01
    drop["release_angle"] = min(drop["release_angle"], 0.0)
    assert_invalid(quiet_call(model, n_flights=N_FLIGHTS, **drop), 1)


@given(drops(), st.floats(0.0, 1.0), GEOMETRIC)
def test_height_beyond_reach_is_invalid(drop, excess, model):
    drop["height"] = (L_TOTAL - drop["pivot"]) * (1.0 + excess)  # h ≥ L − d
    assert_invalid(quiet_call(model, n_flights=N_FLIGHTS, **drop), 2)


BAD_ALPHAS = st.one_of(st.floats(max_value=0.0), st.floats(min_value=1.0, exclude_min=True),
                      st.just(np.nan))


@given(drops(), BAD_ALPHAS, GEOMETRIC)
def test_alpha_outside_unit_interval_is_invalid(drop, alpha, model):
    """Any α ∉ (0, 1], however large, NaN or infinite (non-finite: its own reason)."""
    drop["alpha"] = alpha
    assert_invalid(quiet_call(model, n_flights=N_FLIGHTS, **drop),
                   7 if np.isfinite(alpha) else NOT_FINITE)


@given(st.one_of(st.floats(-10.0, 0.0), st.floats(1.0, 10.0, exclude_min=True),
                 st.sampled_from([np.nan, np.inf, -np.inf])))
def test_alpha_outside_unit_interval_is_invalid_powerlaw(alpha):
    """Power law; |α| ≤ 10 (larger ones are tested below)."""
    assert_invalid(quiet_call("powerlaw", alpha=alpha, t_b=0.2, n_flights=N_FLIGHTS),
                   7 if np.isfinite(alpha) else NOT_FINITE)


@given(drops(alpha=0.95), st.floats(1.0, 1.5))
def test_rebound_over_the_top_is_invalid(drop, factor):
    """A release speed that sends the first rebound (m_1 ≥ 1) over the top."""
    arm = L_TOTAL - drop["pivot"]
    _, l_c, k_o = (float(x) for x in STICK.mass_properties(drop["pivot"]))
    gamma = G * (l_c - drop["pivot"]) / k_o**2
    s_c = (1 - drop["height"] / arm) / 2
    s_0 = (1 - np.sin(drop["release_angle"])) / 2
    # m_1 = s_C + α² (m0 − s_C) with m0 = s_0 + ω0²/(4γ); make m_1 = factor ≥ 1.
    m0 = s_c + (factor - s_c) / drop["alpha"] ** 2
    drop["release_speed"] = np.sqrt(4 * gamma * max(m0 - s_0, 0.0)) * arm * 1.000001
    assert_invalid(quiet_call("pendulum", n_flights=N_FLIGHTS, **drop), 8)
    assert quiet_call("pendulum", n_flights=0, **drop).valid[0]  # no rebound, no problem
    assert quiet_call("small-angle", n_flights=N_FLIGHTS, **drop).valid[0]  # no top there


@pytest.mark.parametrize("model", ["small-angle", "pendulum"])
@pytest.mark.parametrize(("change", "code"), [
    ({"pivot": -0.01}, 10),
    ({"height": 0.0}, 3),
    ({"height": -0.05}, 3),
    ({"release_angle": 0.6}, 4),  # below the contact angle (θ_C ≈ 0.29)
    ({"release_angle": -0.5 * np.pi}, 5),
    ({"release_angle": 2.0}, 5),
    ({"release_speed": -0.1}, 6),
    ({"pivot": np.nan}, NOT_FINITE),
    ({"height": np.nan}, NOT_FINITE),
    ({"release_angle": np.nan}, NOT_FINITE),
    ({"release_speed": np.nan}, NOT_FINITE),
])
def test_every_reason_code(model, change, code):
    """Each way a set-up can fail gives its own reason, quietly."""
    drop = {"alpha": 0.9, "pivot": 0.131, "height": 0.08, "stick": STICK, **change}
    assert_invalid(quiet_call(model, n_flights=5, **drop), code)


@pytest.mark.parametrize("t_b", [0.0, -0.2, np.nan])
def test_powerlaw_bad_t_b(t_b):
    assert_invalid(quiet_call("powerlaw", alpha=0.9, t_b=t_b, n_flights=5),
                   9 if np.isfinite(t_b) else NOT_FINITE)


# --------------------------------------------------------------------------------------------
# Edge cases that once failed: near-upright releases, huge or infinite inputs.
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("speed", [0.0, 1.0])
def test_release_nearly_upright_is_quiet(speed):
    """A valid release angle (|θ0| < π/2) just short of upright must not warn."""
    result = quiet_call("pendulum", alpha=0.5, n_flights=3, pivot=0.131, height=0.08,
                        release_angle=-0.5 * np.pi + 1e-9, release_speed=speed, stick=STICK)
    assert result.valid[0] and np.isfinite(result.t_c[0])


@pytest.mark.parametrize("alpha", [1e8, -5.1e7])
def test_powerlaw_huge_invalid_alpha_is_quiet(alpha):
    assert_invalid(quiet_call("powerlaw", alpha=alpha, t_b=0.2, n_flights=N_FLIGHTS), 7)


def test_invalid_point_keeps_its_alpha():
    result = quiet_call("pendulum", alpha=[1.5, 0.9], n_flights=3, pivot=[0.131, 0.3],
                        height=0.08, stick=STICK)
    np.testing.assert_array_equal(result.alpha, [1.5, 0.9])


@pytest.mark.parametrize("case", ["powerlaw t_b=inf", "small-angle speed=inf"])
def test_infinite_inputs_are_invalid_and_quiet(case):
    if case.startswith("powerlaw"):
        result = quiet_call("powerlaw", alpha=0.9, t_b=np.inf, n_flights=3)
    else:
        result = quiet_call("small-angle", alpha=0.9, n_flights=3, pivot=0.131, height=0.08,
                            release_speed=np.inf, stick=STICK)
    assert not result.valid[0]
