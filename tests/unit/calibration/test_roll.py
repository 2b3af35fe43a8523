"""A simulation of the calibration: θ from the priors (truncated where the physics forbids),
the roll through the model's own forward model, the noise the config names; and the match of
an extractor's onsets with the impacts."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from configs import PAPER_STICK
from drumroll.calibration.recording import match
from drumroll.calibration.roll import OUT_OF_ORDER, PHYSICS, RollSimulator
from drumroll.calibration.run import draw_seeds
from drumroll.config import parse_config
from drumroll.distributions import Fixed
from drumroll.inference.likelihood import OnsetData
from drumroll.inference.scatter import impact_sensitivity
from drumroll.inference.space import SCATTER
from drumroll.onsets import OnsetTable
from drumroll.physics.contact import contact_delays
from paths import DATA


def _config(priors: str, likelihood: str = "", model: str = "pendulum"):
    import tomllib

    text = f'model = "{model}"\n{PAPER_STICK}\n[priors]\n{priors}\n{likelihood}'
    return parse_config(tomllib.loads(text))


PAPER_PRIORS = """\
alpha = { dist = "uniform", low = 0.8, high = 0.95 }
pivot_mm = { dist = "normal", mu = 131, sigma = 2 }
height_mm = { dist = "normal", mu = 80, sigma = 3 }
jitter_ms = { dist = "loguniform", low = 0.01, high = 0.1 }
"""


def test_the_roll_is_the_forward_model_s_plus_the_noise():
    simulator = RollSimulator(_config(PAPER_PRIORS), "pendulum", 16)
    rng = np.random.default_rng(1)
    space = simulator.space
    for _ in range(20):
        roll = simulator.draw(rng)
        x = np.array([[roll.values[name] for name in space.names]])
        impacts, valid = space.impacts(x, 15)
        assert valid[0]
        np.testing.assert_allclose(roll.model_times - roll.t0, impacts[0], atol=1e-12)
        assert np.all(np.diff(roll.times) > 0) and roll.times.size == 16
        # The jitter is at most 0.1 ms: the onsets are the impacts to within a few of it.
        assert np.max(np.abs(roll.times - roll.model_times)) < 6 * roll.values["jitter"]
        for name in space.names:  # every value inside its prior's support
            low, high = space.priors[name].support
            assert low <= roll.values[name] <= high
        bounces = space.bounces(x, 15)
        np.testing.assert_allclose(roll.speeds, bounces.impact_tip_speeds[0])


def test_student_t_noise_is_what_the_likelihood_assumes():
    config = _config(PAPER_PRIORS, '[likelihood]\nnoise = "student-t"\nnu = 4\n')
    simulator = RollSimulator(config, "pendulum", 16)
    rng = np.random.default_rng(2)
    standardised = []
    for _ in range(150):
        roll = simulator.draw(rng)
        standardised += list((roll.times - roll.model_times) / roll.values["jitter"])
    assert stats.kstest(standardised, stats.t(4).cdf).pvalue > 1e-3
    assert stats.kstest(standardised, stats.norm.cdf).pvalue < 1e-3


def test_a_point_the_physics_forbids_is_drawn_again():
    # Heights down to 25 mm: the cone's rim strikes before the tip below ~34 mm.
    priors = PAPER_PRIORS.replace('height_mm = { dist = "normal", mu = 80, sigma = 3 }',
                                  'height_mm = { dist = "uniform", low = 25, high = 90 }')
    simulator = RollSimulator(_config(priors), "pendulum", 16)
    rng = np.random.default_rng(3)
    rolls = [simulator.draw(rng) for _ in range(40)]
    assert sum(r.rejected.get(PHYSICS, 0) for r in rolls) > 0
    assert min(r.values["height"] for r in rolls) > 0.033


def test_onsets_out_of_order_are_drawn_again_and_counted():
    priors = PAPER_PRIORS.replace("low = 0.8, high = 0.95", "low = 0.5, high = 0.7").replace(
        "low = 0.01, high = 0.1", "low = 1, high = 10")
    simulator = RollSimulator(_config(priors), "pendulum", 16)
    rng = np.random.default_rng(4)
    rolls = [simulator.draw(rng) for _ in range(10)]
    assert sum(r.rejected.get(OUT_OF_ORDER, 0) for r in rolls) > 0
    assert all(np.all(np.diff(r.times) > 0) for r in rolls)


@pytest.mark.parametrize(("model", "contact"), [("pendulum", "constant"),
                                               ("powerlaw", "constant"),
                                               ("pendulum/speed", "constant"),
                                               ("pendulum/speed", "hertz")])
def test_a_scattered_restitution_moves_the_impacts_as_the_likelihood_linearises(model,
                                                                                 contact):
    """Impact by impact through the restitution law and the motion's kernel, the impacts move
    by G ε to first order (drumroll.inference.scatter's sensitivity, the law's propagation
    included), the error falling as ε²."""
    priors = PAPER_PRIORS + "restitution_scatter = 0.001\ncontact_ms = 1.0\n"
    if model == "powerlaw":
        priors += 't_b = { dist = "uniform", low = 0.2, high = 0.3 }\n'
    if model.endswith("/speed"):
        priors += "restitution_exponent = 0.2\n"
    config = _config(priors, f'[likelihood]\ncontact = "{contact}"\n', model=model)
    simulator = RollSimulator(config, model, 12)
    assert simulator.scatters
    rng = np.random.default_rng(5)
    roll = simulator.draw(rng)
    space = simulator.space
    x = np.array([[roll.values[name] for name in space.names]])
    impacts, slopes, propagation, _ = space.impacts_and_slopes(x, 11)
    data = OnsetData.from_arrays(roll.times)
    sensitivity = impact_sensitivity(data, slopes, propagation)[0]  # (12, 11)

    _, unscattered_ratios = simulator._scattered_impacts(roll.values, np.zeros(11))

    def error(epsilon):
        exact, ratios = simulator._scattered_impacts(roll.values, epsilon)
        linear = sensitivity @ epsilon
        if contact == "hertz":
            # The likelihood's G holds the contact times at the unscattered speeds: a
            # Hertzian contact time changes with the scattered speed too, to first order
            # (-τ_c ε / 5 per impact), which G leaves out. Taken out here, the rest is G's.
            tau_c = roll.values["contact"]
            linear = linear + (contact_delays(tau_c, 12, ratios[None])
                               - contact_delays(tau_c, 12, unscattered_ratios[None]))[0]
        return np.max(np.abs(exact - impacts[0] - linear)), np.max(np.abs(linear))

    epsilon = 1e-4 * rng.standard_normal(11)
    residual, size = error(epsilon)
    assert residual < 2e-3 * size  # second order in ε: a few 1e-4 of the shift
    half, _ = error(epsilon / 2)
    assert 3.0 < residual / half < 5.0  # ... and it falls as ε²
    unscattered, ratios = simulator._scattered_impacts(roll.values, np.zeros(11))
    np.testing.assert_allclose(unscattered, impacts[0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(ratios, space.bounces(x, 11).speed_ratios[0], rtol=1e-12)


def test_no_scatter_when_it_is_fixed_at_zero():
    simulator = RollSimulator(_config(PAPER_PRIORS + "restitution_scatter = 0\n"), "pendulum", 8)
    assert simulator.space.priors[SCATTER] == Fixed(0.0)
    assert not simulator.scatters


def test_seeds_make_the_same_roll_whatever_else_ran():
    from drumroll.config import load_config

    simulator = RollSimulator(load_config(DATA / "table2_h80.toml"), "pendulum", 16)
    first = simulator.draw(draw_seeds(7, 3)[0])
    simulator.draw(draw_seeds(7, 2)[0])
    again = simulator.draw(draw_seeds(7, 3)[0])
    np.testing.assert_array_equal(first.times, again.times)
    assert draw_seeds(7, 3)[3] == draw_seeds(7, 3)[3] != draw_seeds(7, 4)[3]


def _table(times, bounces=None):
    times = np.asarray(times, float)
    nan = np.full(times.size, np.nan)
    return OnsetTable(times, nan, nan, np.zeros(times.size), bounce=bounces)


def test_onsets_are_matched_with_their_impacts_through_their_numbers():
    impacts = 0.5 + np.concatenate(([0.0], np.cumsum(0.25 * 0.9 ** np.arange(1, 12))))
    hearing, first = match(_table(impacts + 1e-4), impacts)
    assert (first, hearing.n_heard, hearing.misnumbered) == (0, 12, 0)
    assert hearing.median_error_ms == pytest.approx(0.1)
    # The first impact not heard: the roll is numbered from the second.
    hearing, first = match(_table(impacts[1:]), impacts)
    assert (first, hearing.misnumbered) == (1, 0)
    # A tap where the flights put an earlier impact, taken for bounce 0.
    hearing, first = match(_table(np.r_[impacts[0] - 0.27, impacts]), impacts)
    assert (first, hearing.misnumbered, hearing.n_heard) == (-1, 1, 13)
    # A bounce not heard in the middle: a gap in the numbers, nothing misnumbered.
    kept = np.r_[0:5, 6:12]
    hearing, first = match(_table(impacts[kept], kept), impacts)
    assert (first, hearing.misnumbered) == (0, 0)


def test_the_extractor_s_time_limit_stops_a_block_in_the_main_thread_only():
    import threading
    import time

    from drumroll.calibration.recording import TooSlow, time_limit

    started = time.perf_counter()
    with pytest.raises(TooSlow), time_limit(0.2):
        time.sleep(5)
    assert time.perf_counter() - started < 2
    with time_limit(5):  # a block that ends in time: nothing left armed
        pass
    time.sleep(0.05)
    outcome = []

    def elsewhere():
        with time_limit(0.01):
            time.sleep(0.1)
        outcome.append("ran without a limit")

    thread = threading.Thread(target=elsewhere)
    thread.start()
    thread.join()
    assert outcome == ["ran without a limit"]
