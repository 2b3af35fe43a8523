"""Several independent priors evaluated together: the sampler's vectorised prior.

:class:`PriorTable` turns a tuple of :class:`~drumroll.inference.priors.Prior` objects (one per
sampled column) into a handful of array operations per call, for the log density and the
unit-cube transform; it gives exactly what the priors' own methods give (tested).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import special

from drumroll.inference.priors import (
    _LOG_SQRT_2PI,
    HalfNormal,
    LogNormal,
    LogUniform,
    Normal,
    Prior,
    Uniform,
)


class PriorTable:
    """The log density of several independent priors, one per column, in a few array ops.

    :meth:`ParameterSpace.log_prior` calls it once per sampler step, so instead of one
    :meth:`Prior.logpdf` per column it evaluates every column of a family at once: the support
    check is one comparison against vectors of bounds, Uniform columns add a constant, Normal
    and HalfNormal columns one sum of squares, LogUniform and LogNormal columns one ``log``.
    Families it does not know (Beta, Fixed, user subclasses) fall back to their own
    :meth:`Prior.logpdf`. The result equals the sum of the columns' ``logpdf`` to rounding.
    """

    def __init__(self, priors: tuple[Prior, ...]) -> None:
        self.lower = np.array([p.support[0] for p in priors], float)
        self.upper = np.array([p.support[1] for p in priors], float)
        self.constant = 0.0
        normal: list[tuple[int, float, float]] = []
        log_x: list[int] = []
        log_normal: list[tuple[int, float, float]] = []
        self.other: list[tuple[int, Prior]] = []
        for i, p in enumerate(priors):
            kind = type(p)
            if kind is Uniform:
                self.constant += -math.log(p.high - p.low) - p._log_mass
            elif kind is LogUniform:
                self.constant += -math.log(math.log(p.high / p.low)) - p._log_mass
                log_x.append(i)
            elif kind is Normal:
                self.constant += -math.log(p.sigma) - _LOG_SQRT_2PI - p._log_mass
                normal.append((i, p.mu, p.sigma))
            elif kind is HalfNormal:
                self.constant += (-math.log(p.sigma) - _LOG_SQRT_2PI + math.log(2.0)
                                  - p._log_mass)
                normal.append((i, 0.0, p.sigma))
            elif kind is LogNormal:
                self.constant += -math.log(p.sigma) - _LOG_SQRT_2PI - p._log_mass
                log_normal.append((i, p.mu, p.sigma))
            else:
                self.other.append((i, p))
        self._build_ppf(priors)
        # One-point evaluation (nested sampling, optimisers): (kind, lower, upper, constant,
        # mu, sigma, prior) per column, evaluated with ``math``.
        self.columns: list[tuple[str, float, float, float, float, float, Prior]] = []
        for i, p in enumerate(priors):
            kind = type(p)
            lo, hi = float(self.lower[i]), float(self.upper[i])
            if kind is Uniform:
                self.columns.append(("const", lo, hi, -math.log(p.high - p.low) - p._log_mass,
                                     0.0, 1.0, p))
            elif kind is LogUniform:
                self.columns.append(("log", lo, hi, -math.log(math.log(p.high / p.low))
                                     - p._log_mass, 0.0, 1.0, p))
            elif kind in (Normal, HalfNormal):
                mu = p.mu if kind is Normal else 0.0
                c = -math.log(p.sigma) - _LOG_SQRT_2PI - p._log_mass + (
                    math.log(2.0) if kind is HalfNormal else 0.0)
                self.columns.append(("normal", lo, hi, c, mu, p.sigma, p))
            elif kind is LogNormal:
                self.columns.append(("lognormal", lo, hi,
                                     -math.log(p.sigma) - _LOG_SQRT_2PI - p._log_mass,
                                     p.mu, p.sigma, p))
            else:
                self.columns.append(("other", lo, hi, 0.0, 0.0, 1.0, p))
        self.normal_index = np.array([i for i, _, _ in normal], int)
        self.normal_mu = np.array([m for _, m, _ in normal], float)
        self.normal_sigma = np.array([s for _, _, s in normal], float)
        self.log_index = np.array(log_x, int)
        self.lognormal_index = np.array([i for i, _, _ in log_normal], int)
        self.lognormal_mu = np.array([m for _, m, _ in log_normal], float)
        self.lognormal_sigma = np.array([s for _, _, s in log_normal], float)

    def _build_ppf(self, priors: tuple[Prior, ...]) -> None:
        """Quantile functions as x = f(a + b q) per family, q = cdf_lo + u × mass."""
        n = len(priors)
        self.ppf_offset, self.ppf_scale = np.zeros(n), np.ones(n)
        groups: dict[str, list[tuple[int, float, float]]] = {
            "affine": [], "exp_affine": [], "gauss": [], "exp_gauss": []}
        for i, p in enumerate(priors):
            kind = type(p)
            if kind in (Uniform, LogUniform, Normal, HalfNormal, LogNormal):
                self.ppf_offset[i], self.ppf_scale[i] = p._cdf_lo, p._mass
            if kind is Uniform:
                groups["affine"].append((i, p.low, p.high - p.low))
            elif kind is LogUniform:
                groups["exp_affine"].append((i, math.log(p.low), math.log(p.high / p.low)))
            elif kind is Normal:
                groups["gauss"].append((i, p.mu, p.sigma))
            elif kind is HalfNormal:  # σ ndtri((1 + q) / 2)
                self.ppf_offset[i] = 0.5 * (1.0 + p._cdf_lo)
                self.ppf_scale[i] = 0.5 * p._mass
                groups["gauss"].append((i, 0.0, p.sigma))
            elif kind is LogNormal:
                groups["exp_gauss"].append((i, p.mu, p.sigma))
        for name, rows in groups.items():
            setattr(self, name, np.array([i for i, _, _ in rows], int))
            a = np.array([a for _, a, _ in rows], float)
            b = np.array([b for _, _, b in rows], float)
            prefix = {"affine": "affine", "exp_affine": "exp", "gauss": "gauss_mu",
                      "exp_gauss": "exp_gauss_mu"}[name]
            if name in ("gauss", "exp_gauss"):
                setattr(self, prefix, a)
                setattr(self, prefix.replace("_mu", "_sigma"), b)
            else:
                setattr(self, f"{prefix}_a", a)
                setattr(self, f"{prefix}_b", b)

    def __call__(self, x: NDArray) -> NDArray:
        """Sum of the columns' log densities, shape ``(batch,)``; −inf outside a support."""
        inside = ((x >= self.lower) & (x <= self.upper)).all(axis=1)
        if not inside.all():
            out = np.full(x.shape[0], -np.inf)
            if inside.any():
                out[inside] = self(x[inside])
            return out
        total = np.full(x.shape[0], self.constant)
        if self.normal_index.size:
            z = (x[:, self.normal_index] - self.normal_mu) / self.normal_sigma
            total -= 0.5 * (z * z).sum(axis=1)
        if self.log_index.size:
            total -= np.log(x[:, self.log_index]).sum(axis=1)
        if self.lognormal_index.size:
            log_x = np.log(x[:, self.lognormal_index])
            z = (log_x - self.lognormal_mu) / self.lognormal_sigma
            total -= (0.5 * z * z + log_x).sum(axis=1)
        for i, prior in self.other:
            total += prior.logpdf(x[:, i])
        return total

    def log_pdf_one(self, row: list[float]) -> float:
        """:meth:`__call__` for one point given as a list of floats (−inf outside)."""
        total = 0.0
        for value, (kind, lo, hi, c, mu, sigma, prior) in zip(row, self.columns, strict=True):
            if not lo <= value <= hi:
                return -math.inf
            if kind == "const":
                total += c
            elif kind == "normal":
                z = (value - mu) / sigma
                total += c - 0.5 * z * z
            elif kind == "log":
                total += c - math.log(value)
            elif kind == "lognormal":
                log_x = math.log(value)
                z = (log_x - mu) / sigma
                total += c - 0.5 * z * z - log_x
            else:
                total += float(prior.logpdf(value))
        return total

    def ppf(self, u: NDArray) -> NDArray:
        """Every column's quantile function at once: the unit cube onto the priors."""
        u = np.asarray(u, float)
        out = np.empty_like(u)
        q = self.ppf_offset + self.ppf_scale * u  # the truncated families' CDF levels
        if self.affine.size:
            out[..., self.affine] = self.affine_a + self.affine_b * q[..., self.affine]
        if self.exp_affine.size:
            out[..., self.exp_affine] = np.exp(self.exp_a + self.exp_b * q[..., self.exp_affine])
        if self.gauss.size:
            out[..., self.gauss] = (self.gauss_mu
                                    + self.gauss_sigma * special.ndtri(q[..., self.gauss]))
        if self.exp_gauss.size:
            out[..., self.exp_gauss] = np.exp(
                self.exp_gauss_mu + self.exp_gauss_sigma * special.ndtri(q[..., self.exp_gauss]))
        for i, prior in self.other:
            out[..., i] = prior.ppf(u[..., i])
        return np.clip(out, self.lower, self.upper)

