"""Densities more than one stage of the pipeline uses, each written once."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import gammaln


def student_t_logpdf(z2: ArrayLike, nu: ArrayLike, log_scale: ArrayLike = 0.0) -> NDArray:
    """Log density of a Student t with ``nu`` degrees of freedom and scale s at a point whose
    standardised squared distance from the centre is ``z2`` = ((x − μ)/s)²; ``log_scale`` is
    log s (the density of x, not of the standardised variable)."""
    nu = np.asarray(nu, float)
    return (gammaln(0.5 * (nu + 1.0)) - gammaln(0.5 * nu) - 0.5 * np.log(nu * math.pi)
            - log_scale - 0.5 * (nu + 1.0) * np.log1p(np.asarray(z2, float) / nu))
