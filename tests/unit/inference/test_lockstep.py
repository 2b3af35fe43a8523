"""Searches run in lockstep give what they give one after another, in fewer calls."""

from __future__ import annotations

import threading
from functools import partial

import numpy as np
import pytest

from drumroll.config import load_config
from drumroll.inference.coordinates import SamplerCoordinates
from drumroll.inference.lockstep import lockstep
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.sampling import SamplerTarget, climb
from drumroll.pipeline import choose_roll, load_onsets
from tests.paths import DATA


class _Counted:
    """A target that counts its calls (and the threads that made them)."""

    def __init__(self, target: SamplerTarget) -> None:
        self.target, self.calls, self.threads = target, 0, set()
        self.coordinates = target.coordinates

    def __call__(self, z: np.ndarray) -> np.ndarray:
        self.calls += 1
        self.threads.add(threading.get_ident())
        return self.target(z)


@pytest.fixture(scope="module")
def pendulum_target() -> SamplerTarget:
    config = load_config(DATA / "table2_h80.toml")
    data = choose_roll(load_onsets(DATA / "table2_h80.flac")).data
    log_posterior = LogPosterior.build(config, "pendulum", data, "student-t")
    return SamplerTarget(log_posterior, SamplerCoordinates(log_posterior.space, data))


def test_climbs_in_lockstep_equal_climbs_one_after_another(pendulum_target):
    """Four L-BFGS-B climbs of the exact pendulum's posterior from prior draws: the same
    points and densities to the last bit, in under half the calls of the target."""
    rng = np.random.default_rng(3)
    coordinates = pendulum_target.coordinates
    z = coordinates.to_sampler(pendulum_target.log_posterior.space.sample_prior(rng, 2000),
                               t0_centred=True)
    density = pendulum_target(z)
    starts = z[np.argsort(np.where(np.isfinite(density), density, -np.inf))[::-1][:4]]
    spread = np.std(z[np.isfinite(density)], axis=0)
    spread = np.where(spread > 0, spread, 1.0)  # T0's column, held at 0 (as find_start does)

    alone = _Counted(pendulum_target)
    one_by_one = [climb(alone, start, spread) for start in starts]
    together = _Counted(pendulum_target)
    side_by_side = lockstep(together, [partial(climb, start=s, spread=spread) for s in starts])

    for (point, value), (point_2, value_2) in zip(one_by_one, side_by_side, strict=True):
        assert np.array_equal(point, point_2) and value == value_2
    assert together.calls < 0.5 * alone.calls
    assert len(together.threads) > 1  # the calls were made from the searches' threads


def test_an_error_in_one_search_stops_the_others_and_is_raised():
    calls = []

    def function(points):
        calls.append(len(points))
        return points.sum(axis=1)

    def failing(f):
        f(np.ones((1, 2)))
        raise ValueError("this search failed")

    def endless(f):
        while True:  # stops only when abandoned
            f(np.ones((2, 2)))

    with pytest.raises(ValueError, match="this search failed"):
        lockstep(function, [endless, failing, endless])
    assert calls[0] == 5  # the first call of all three, as one


def test_one_search_runs_alone_in_this_thread():
    here = threading.get_ident()
    seen = []
    assert lockstep(lambda p: p, [lambda f: seen.append(threading.get_ident()) or 7]) == [7]
    assert seen == [here]
