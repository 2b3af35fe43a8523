"""Restitution laws (drumroll.physics.restitution) against independent references.

The speed law 1 − α(v) = (1 − α)(v / v₁)^p is checked where it acts: the exact pendulum's
flights against direct integration of θ̈ = γ cos θ, each flight launched at α(v) times the
speed the ODE itself landed with (so the recursion of the module is never used), and the power
law against the same rule applied bounce by bounce in plain Python.
"""

from __future__ import annotations

import numpy as np
import pytest

from drumroll.config import parse_config
from drumroll.errors import ConfigError
from drumroll.physics import REASONS, bounce_sequence
from drumroll.physics.models import MODELS, forward_model
from drumroll.physics.restitution import LAWS
from tests.unit.physics.test_pendulum import STICK, contact_speed, ode_travel, stick_constants


def _speed_law(alpha: float, exponent: float, speed: float, first: float) -> float:
    return 1.0 - (1.0 - alpha) * (speed / first) ** exponent


@pytest.mark.parametrize(("alpha", "exponent"), [(0.8, 0.2), (0.6, 0.5), (0.9, -0.3)])
def test_pendulum_speed_law_matches_the_ode_relaunched_at_each_landing(alpha, exponent):
    pivot, height, n = 0.131, 0.08, 8
    gamma, arm, _ = stick_constants(pivot)
    theta_c = float(np.arcsin(height / arm))
    landing = omega_c = contact_speed(gamma, 0.0, 0.0, theta_c)
    flights = []
    for _ in range(n):  # each flight lands as fast as it left: the next impact's speed
        launch = _speed_law(alpha, exponent, landing, omega_c) * landing
        travel = ode_travel(gamma, theta_c, -launch, theta_c)
        flights.append(travel.time)
        landing = abs(travel.omega_end)
    model = bounce_sequence("pendulum/speed", alpha=alpha, restitution_exponent=exponent,
                            n_flights=n, pivot=pivot, height=height, stick=STICK)
    assert model.valid.all()
    np.testing.assert_allclose(model.flights[0], flights, rtol=0, atol=1e-9)


def test_power_law_speed_law_matches_a_bounce_by_bounce_loop():
    alpha, t_b, exponent, n = 0.9, 0.25, 0.4, 30
    flight, expected = t_b, []
    for _ in range(n):  # the flight time stands for the speed (it is proportional to it)
        flight *= _speed_law(alpha, exponent, flight, t_b)
        expected.append(flight)
    model = bounce_sequence("powerlaw/speed", alpha=alpha, t_b=t_b,
                            restitution_exponent=exponent, n_flights=n)
    np.testing.assert_allclose(model.flights[0], expected, rtol=1e-13)
    # The ratio of successive flights climbs towards 1 as the bouncer slows.
    ratios = model.flights[0, 1:] / model.flights[0, :-1]
    assert np.all(np.diff(ratios) > 0) and ratios[0] > alpha


@pytest.mark.parametrize("motion", ["powerlaw", "small-angle", "pendulum"])
def test_exponent_zero_is_the_constant_law(motion):
    common = dict(alpha=np.array([0.7, 0.95]), n_flights=12)
    if motion == "powerlaw":
        common["t_b"] = 0.3
    else:
        common.update(pivot=0.12, height=0.1, stick=STICK, release_speed=0.2)
    constant = bounce_sequence(motion, **common)
    speed = bounce_sequence(f"{motion}/speed", restitution_exponent=0.0, **common)
    np.testing.assert_allclose(speed.flights, constant.flights, rtol=1e-12)
    np.testing.assert_allclose(speed.impact_tip_speeds, constant.impact_tip_speeds, rtol=1e-12)


def test_sampler_path_equals_the_public_path():
    forward = forward_model("pendulum/speed")
    values = {"alpha": np.array([0.85, 0.9, 0.7]), "pivot": np.array([0.12, 0.13, 0.11]),
              "height": np.array([0.06, 0.09, 0.12]), "release_speed": 0.1,
              "release_angle": 0.0, "restitution_exponent": np.array([0.2, 0.6, -0.2]),
              "stick_length": 0.348, "stick_tip": 0.06, "stick_radius": 0.0075}
    flights, valid = forward.flights(values, 10, "cylinder-cone")
    public = forward.bounces(values, 10, STICK)
    assert valid.all() and public.valid.all()
    np.testing.assert_allclose(flights, public.flights, rtol=1e-12)


def test_a_law_whose_harder_impacts_rebound_slower_is_no_bouncer():
    """dr_k/dr_{k−1} > 0 fails when p (1 − α) ≥ α: the point is invalid, with its reason."""
    model = bounce_sequence("powerlaw/speed", alpha=0.3, t_b=0.2, restitution_exponent=3.0,
                            n_flights=5)
    assert not model.valid[0]
    assert "rebound slower" in REASONS[int(model.reason[0])]
    _, valid = forward_model("powerlaw/speed").flights(
        {"alpha": np.array([0.3, 0.9]), "t_b": 0.2, "restitution_exponent": 3.0}, 5)
    assert valid.tolist() == [False, True]


def test_model_names_and_default_prior():
    assert set(MODELS) == {"powerlaw", "small-angle", "pendulum", "powerlaw/speed",
                           "small-angle/speed", "pendulum/speed"}
    assert MODELS["pendulum/speed"].parameters[-1] == "restitution_exponent"
    config = parse_config({"model": "powerlaw/speed", "compare": ["powerlaw/constant"],
                           "priors": {"alpha": 0.9, "t_b": 0.2}})
    assert config.model == "powerlaw/speed" and config.compare == ("powerlaw",)
    prior = config.priors["restitution_exponent"]
    assert prior.median() == pytest.approx(0.0)
    with pytest.raises(ConfigError, match="model"):
        parse_config({"model": "powerlaw/drag", "priors": {"alpha": 0.9, "t_b": 0.2}})


@pytest.mark.parametrize("law", list(LAWS))
def test_each_step_of_the_ratios_is_the_law_s_restitution(law):
    """restitution(r_{k-1}) is the step r_k / r_{k-1} of speed_ratios (what a caller that
    carries the speeds itself, the calibration's scattered roll, takes one impact at a
    time)."""
    alpha = np.array([0.6, 0.85, 0.97])
    values = {"restitution_exponent": np.array([0.1, 0.2, 0.3])}
    ratios, valid = LAWS[law].speed_ratios(alpha, values, 12)
    assert valid.all()
    before = np.concatenate([np.ones((3, 1)), ratios[:, :-1]], axis=1)
    for k in range(12):
        step = LAWS[law].restitution(alpha, values, before[:, k])
        np.testing.assert_allclose(ratios[:, k], before[:, k] * step, rtol=1e-14)
