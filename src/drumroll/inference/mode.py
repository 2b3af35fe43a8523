"""Finding the posterior mode, where the walkers start."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import optimize

from drumroll.errors import OnsetsOutsidePriors
from drumroll.inference.posterior import LogPosterior


def find_mode(log_posterior: LogPosterior, rng: np.random.Generator, n_starts: int = 4,
              n_candidates: int = 2000) -> NDArray:
    """The highest-posterior point found by Nelder–Mead from several starts.

    The starts are the best of ``n_candidates`` prior draws (one vectorised call), so a
    multimodal or ridge-shaped posterior is approached from several sides. Each search runs in
    coordinates scaled by the spread of the candidates, so that millimetres and milliseconds
    are optimised alike.

    Returns
    -------
    NDArray
        The best point, shape ``(ndim,)``.
    """
    space = log_posterior.space
    candidates = space.sample_prior(rng, n_candidates)
    values = log_posterior(candidates)
    finite = np.isfinite(values)
    if not finite.any():
        raise OnsetsOutsidePriors(space.model)
    order = np.argsort(values[finite])[::-1]
    starts = candidates[finite][order[:n_starts]]
    scale = np.std(candidates[finite], axis=0)
    scale = np.where(scale > 0, scale, 1.0)

    def negative(z: NDArray) -> float:
        value = log_posterior(z * scale)
        return -value if np.isfinite(value) else 1e300

    best, best_value = starts[0], -np.inf
    for start in starts:
        result = optimize.minimize(negative, start / scale, method="Nelder-Mead",
                                   options={"xatol": 1e-6, "fatol": 1e-4, "adaptive": True,
                                            "maxiter": 200 * space.ndim})
        if -result.fun > best_value:
            best, best_value = result.x * scale, -result.fun
    return best
