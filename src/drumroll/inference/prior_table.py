"""Several independent priors evaluated together: the sampler's vectorised prior.

:class:`PriorTable` turns a tuple of :class:`~drumroll.distributions.Distribution` objects (one per
sampled column) into one call per distribution family, for the log density and the unit-cube
transform: each family's own kernels (:meth:`~drumroll.distributions.Truncated.density`,
:meth:`~drumroll.distributions.Truncated.quantile`) evaluated on all its columns at once,
with their parameters as vectors. No formula is written here, so the table gives exactly what
the priors' own methods give.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from drumroll.distributions import Distribution, Truncated


class _Family:
    """The columns of one family: their indices and their parameters as vectors."""

    def __init__(self, kind: type[Truncated], columns: list[tuple[int, Truncated]]) -> None:
        self.kind = kind
        self.index = np.array([i for i, _ in columns], int)
        first = columns[0][1]
        self.params = tuple(np.array([getattr(p, name) for _, p in columns], float)
                            for name in first.params)
        self.cdf_lo = np.array([p._cdf_lo for _, p in columns], float)
        self.mass = np.array([p.mass for _, p in columns], float)
        self.log_mass = float(sum(p.log_mass for _, p in columns))


class PriorTable:
    """The log density and quantile functions of several independent priors, one per column.

    :meth:`ParameterSpace.log_prior` calls it once per sampler step, so instead of one
    :meth:`Distribution.logpdf` per column it evaluates every column of a family at once: the
    support check is one comparison against vectors of bounds, each family one call of its
    density.
    Fixed values and priors that are no truncated family fall back to their own methods.
    """

    def __init__(self, priors: tuple[Distribution, ...]) -> None:
        self.lower = np.array([p.support[0] for p in priors], float)
        self.upper = np.array([p.support[1] for p in priors], float)
        by_kind: dict[type, list[tuple[int, Truncated]]] = {}
        self.other: list[tuple[int, Distribution]] = []
        for i, p in enumerate(priors):
            if isinstance(p, Truncated):
                by_kind.setdefault(type(p), []).append((i, p))
            else:
                self.other.append((i, p))
        families = [_Family(kind, cols) for kind, cols in by_kind.items()]
        self.constant = -sum(f.log_mass for f in families)
        # A flat family adds the same everywhere inside the support: once, here.
        for f in families:
            if by_kind[f.kind][0][1].flat:
                inside = np.array([[p.median() for _, p in by_kind[f.kind]]])
                self.constant += float(f.kind.density(inside, *f.params).sum())
        self.families = [f for f in families if not by_kind[f.kind][0][1].flat]
        self.flat = [f for f in families if by_kind[f.kind][0][1].flat]

    def __call__(self, x: NDArray) -> NDArray:
        """Sum of the columns' log densities, shape ``(batch,)``; −inf outside a support."""
        inside = ((x >= self.lower) & (x <= self.upper)).all(axis=1)
        if not inside.all():
            out = np.full(x.shape[0], -np.inf)
            if inside.any():
                out[inside] = self(x[inside])
            return out
        total = np.full(x.shape[0], self.constant)
        for f in self.families:
            total += f.kind.density(x[:, f.index], *f.params).sum(axis=1)
        for i, prior in self.other:
            total += prior.logpdf(x[:, i])
        return total

    def log_pdf_one(self, row: list[float]) -> float:
        """:meth:`__call__` for one point given as a list of floats (−inf outside)."""
        return float(self(np.asarray([row], float))[0])

    def ppf(self, u: NDArray) -> NDArray:
        """Every column's quantile function at once: the unit cube onto the priors."""
        u = np.asarray(u, float)
        out = np.empty_like(u)
        for f in (*self.families, *self.flat):
            q = f.cdf_lo + f.mass * u[..., f.index]  # the truncated family's CDF levels
            out[..., f.index] = f.kind.quantile(q, *f.params)
        for i, prior in self.other:
            out[..., i] = prior.ppf(u[..., i])
        return np.clip(out, self.lower, self.upper)
