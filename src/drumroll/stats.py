"""Densities and summaries more than one stage of the pipeline uses, each written once."""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray


def student_t_logpdf(z2: ArrayLike, nu: ArrayLike, log_scale: ArrayLike = 0.0) -> NDArray:
    """Log density of a Student t with ``nu`` degrees of freedom and scale s at a point whose
    standardised squared distance from the centre is ``z2`` = ((x − μ)/s)²; ``log_scale`` is
    log s (the density of x, not of the standardised variable).

    ``nu`` may be an array (the inference's sampled ν). scipy's ``gammaln`` is imported on
    the first call, not with this module: the onset detector, which imports this module but
    uses only :func:`student_t_logpdf_fixed`, then never loads :mod:`scipy.special`.
    """
    gammaln = _gammaln()
    nu = np.asarray(nu, float)
    return (gammaln(0.5 * (nu + 1.0)) - gammaln(0.5 * nu) - 0.5 * np.log(nu * math.pi)
            - log_scale - 0.5 * (nu + 1.0) * np.log1p(np.asarray(z2, float) / nu))


def student_t_logpdf_fixed(z2: ArrayLike, nu: float, log_scale: ArrayLike = 0.0) -> NDArray:
    """:func:`student_t_logpdf` for one number ``nu`` (a setting, not a parameter): the
    normalising constant from :func:`math.lgamma`, computed once per ``nu``. It agrees with
    scipy's ``gammaln`` to within a few units in the last place (1e-15), which no onset
    decision can see."""
    nu = float(nu)
    return (student_t_log_norm(nu) - log_scale
            - 0.5 * (nu + 1.0) * np.log1p(np.asarray(z2, float) / nu))


@functools.lru_cache(maxsize=64)
def student_t_log_norm(nu: float, dim: int = 1) -> float:
    """log of the normalising constant of a ``dim``-variate Student t with unit scale,
    Γ((ν+d)/2) / (Γ(ν/2) (νπ)^(d/2))."""
    return (math.lgamma(0.5 * (nu + dim)) - math.lgamma(0.5 * nu)
            - 0.5 * dim * math.log(nu * math.pi))


@functools.cache
def _gammaln():
    from scipy.special import gammaln  # a fifth of a second: loaded when first needed

    return gammaln


def central_band(draws: NDArray[np.float64], prob: float = 0.9
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Lower edge, median and upper edge of the central ``prob`` interval along axis 0."""
    lo, mid, hi = np.nanquantile(draws, [(1 - prob) / 2, 0.5, (1 + prob) / 2], axis=0)
    return lo, mid, hi


def hdi(draws: ArrayLike, prob: float = 0.9) -> tuple[float, float]:
    """The narrowest interval holding ``prob`` of the draws (all of them, flattened): the
    highest-density interval of a unimodal posterior, as ``arviz.hdi`` computes it (the
    shortest of the windows spanning ⌊prob n⌋ sorted draws; NaN draws give NaN)."""
    ordered = np.sort(np.asarray(draws, float).ravel())
    n = ordered.size
    inside = math.floor(prob * n)
    if n - inside <= 0:
        raise ValueError("too few draws for an interval")
    widths = ordered[inside:] - ordered[:n - inside]
    first = int(np.argmin(widths))
    return float(ordered[first]), float(ordered[first + inside])
