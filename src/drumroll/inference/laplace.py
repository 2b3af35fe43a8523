"""Laplace's method: the Gaussian a log density fits at its mode, and the integral it gives.

Two users: the screens of other numberings (:func:`~drumroll.inference.missed_impacts.screen`,
ln Z of each) and the sampler's start (:func:`~drumroll.inference.sampling.laplace_ball`,
walkers drawn from the fitted Gaussian rather than from a tiny ball).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import special


@dataclass(frozen=True)
class LaplaceEstimate:
    """Laplace's method at a mode: ln ∫ exp(density) (NaN where it has no answer), and the
    Gaussian it fits there (``covariance`` = (−H)⁻¹; None where −H is not positive definite)."""

    log_z: float
    mode: NDArray
    covariance: NDArray | None = None


def laplace(density: Callable[[NDArray], NDArray], mode: NDArray, box: NDArray
            ) -> LaplaceEstimate:
    """ln ∫ exp(density) over ``box`` by Laplace's method at ``mode``.

    Inside the box: ln p(z*) + (d/2) ln 2π − ½ ln det(−H), the Hessian H by central
    differences in one batched call, each step a thousandth of its column's curvature scale.
    A column whose mode lies on the box's edge (a prior's bound: the contact time at the end
    of its range) is integrated over its one side: with the other columns integrated out as
    a Gaussian, the density falls away from the edge with the slope g and the marginal
    curvature c (H's Schur complement, H taken a few steps inside), and
    ∫₀^∞ exp(−g u − ½|c| u²) du = √(π / 2|c|) erfcx(g / √(2|c|)); several such columns are
    taken as independent. NaN where a difference leaves the support or −H is not positive
    definite.
    """
    d = mode.size
    centre = float(density(mode[None])[0])
    if not np.isfinite(centre):
        return LaplaceEstimate(math.nan, mode)
    low, high = box[:, 0], box[:, 1]
    width = np.where(np.isfinite(high - low), high - low, np.nan)
    reach = 1e-6 * np.where(np.isfinite(width), width, 1.0)
    inward = np.where(mode - low <= reach, 1.0, np.where(high - mode <= reach, -1.0, 0.0))
    unit = np.eye(d)
    for _ in range(2):
        edge = inward != 0.0
        # Rough curvature scales: central differences inside, one-sided ones on an edge.
        rough = 1e-4 * np.where(edge & np.isfinite(width), width,
                                np.maximum(np.abs(mode), 1.0))
        offsets = np.where(edge, inward, 1.0)[:, None] * rough[:, None] * unit
        second = np.where(edge, 2.0, -1.0)[:, None] * offsets
        around = density(mode + np.concatenate([offsets, second]))
        first, other = around[:d], around[d:]
        # A mode against the edge of the region the physics allows (a renumbered roll that
        # the stick can only just make) has one side of a column forbidden: an edge too.
        implicit = ~edge & (np.isfinite(first) != np.isfinite(other))
        if not implicit.any():
            break
        inward = np.where(implicit, np.where(np.isfinite(first), 1.0, -1.0), inward)
    else:  # the one-sided steps of the edges found met yet more forbidden sides
        return LaplaceEstimate(math.nan, mode)
    with np.errstate(invalid="ignore"):
        curvature = np.where(edge, centre - 2.0 * first + other, first + other - 2.0 * centre
                             ) / rough**2
        # Falling away from the edge (one-sided, second order).
        slope = -(-3.0 * centre + 4.0 * first - other) / (2.0 * rough)
    if not (np.isfinite(curvature).all() and (curvature < 0).all()):
        return LaplaceEstimate(math.nan, mode)
    h = 1e-3 / np.sqrt(-curvature)
    # The Hessian about a point a few steps inside every edge, so that no step leaves it.
    inside = mode + np.where(edge, inward * 3.0 * h, 0.0)
    i, j = np.triu_indices(d)
    signs = np.array([(1, 1), (1, -1), (-1, 1), (-1, -1)], float)
    steps = (signs[None, :, 0, None] * (h[i, None] * unit[i])[:, None, :]
             + signs[None, :, 1, None] * (h[j, None] * unit[j])[:, None, :])
    values = density((inside + steps).reshape(-1, d)).reshape(len(i), 4)
    if not np.isfinite(values).all():
        return LaplaceEstimate(math.nan, mode)
    # (f(++) − f(+−) − f(−+) + f(−−)) / (4 h_i h_j); on the diagonal the steps are 2h_i.
    hessian = np.zeros((d, d))
    hessian[i, j] = hessian[j, i] = ((values[:, 0] - values[:, 1] - values[:, 2] + values[:, 3])
                                     / (4.0 * h[i] * h[j]))
    try:
        covariance = np.linalg.inv(np.linalg.cholesky(-hessian))
        covariance = covariance.T @ covariance
    except np.linalg.LinAlgError:
        covariance = None
    free, edges = np.flatnonzero(~edge), np.flatnonzero(edge)
    negative = -hessian[np.ix_(free, free)]
    sign, log_det = np.linalg.slogdet(negative) if free.size else (1.0, 0.0)
    if sign <= 0:
        return LaplaceEstimate(math.nan, mode, covariance)
    log_z = centre + 0.5 * free.size * math.log(2.0 * math.pi) - 0.5 * log_det
    if edges.size:
        cross = hessian[np.ix_(edges, free)]
        marginal = -(np.diag(hessian[np.ix_(edges, edges)])
                     - np.einsum("ef,ef->e", cross, np.linalg.solve(negative, -cross.T).T))
        for g, c in zip(slope[edges], marginal, strict=True):
            if c > 0.0:
                scale = math.sqrt(2.0 * c)
                log_z += math.log(math.sqrt(math.pi) / scale * special.erfcx(g / scale))
            elif g > 0.0:
                log_z -= math.log(g)
            else:
                return LaplaceEstimate(math.nan, mode, covariance)
    return LaplaceEstimate(log_z, mode, covariance)
