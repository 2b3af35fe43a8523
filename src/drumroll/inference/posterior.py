"""The log posterior that the samplers call: prior + likelihood, vectorised over walkers."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from drumroll.config import Config
from drumroll.distributions import Distribution, Fixed, Uniform
from drumroll.inference.likelihood import (
    T0_WINDOW_S,
    OnsetData,
    gaussian_marginal,
    gaussian_marginal_lean,
    pointwise_log_likelihood,
    student_t,
    student_t_one,
)
from drumroll.inference.scatter import (
    dense_marginal,
    onset_covariance,
    scatter_marginal,
    scatter_noise,
    scatter_pointwise,
    scatter_spread,
    student_t_laplace,
    student_t_laplace_pointwise,
    student_t_scatter_noise,
)
from drumroll.inference.space import SCATTER, ParameterSpace

if TYPE_CHECKING:
    from collections.abc import Callable
    from concurrent.futures import Executor, Future

NOISE_MODELS = ("gaussian", "student-t")
#: Impact times τ_0 … τ_K after the first (every bounce up to the last observed one,
#: K = ``data.n_flights``), ``(batch, K + 1)``, and where they are valid, ``(batch,)``.
Impacts = tuple[NDArray, NDArray]


def t0_window(data: OnsetData) -> tuple[float, float]:
    """The flat prior's range of T0, impact 0's time, under Student-t noise (s).

    Where the first onset is impact 0, :data:`T0_WINDOW_S` about it. Where it is impact k > 0
    (k impacts missed before it), T0 lies before it by the k missed flights, each at least
    as long as the flights heard after it (restitution ≤ 1: flights only shrink), so at
    least k d before it, d the shorter of the first two flights heard (an onset's interval
    over its bounce gap; the shorter, so that one late onset cannot push the bound past the
    truth). The window ends k d / 2 before the first onset (a margin for timing noise and
    contact times) and reaches back over missed flights of up to 2.5 d on average: as wide
    as :data:`T0_WINDOW_S`, so that the numberings' evidences compare, unless the flights
    are longer than that allows. Missed flights that grew back faster than that (one missed
    at a restitution under about 0.63, two under 0.66, three under 0.74) fall outside it,
    and the fit says so (T0 piles up at the window's edge).
    """
    first = float(data.times[0])
    missed = int(data.bounces[0])
    if missed == 0 or data.n_onsets < 2:
        return first - 0.5 * T0_WINDOW_S, first + 0.5 * T0_WINDOW_S
    flights = np.diff(data.times[:3]) / np.diff(data.bounces[:3])
    least = missed * float(flights.min())
    high = first - 0.5 * least
    return high - max(T0_WINDOW_S, 2.0 * least), high


@dataclass(frozen=True)
class Walk:
    """What a scattering restitution's walk needs of a batch of parameter points
    (:mod:`~drumroll.inference.scatter`): impact times τ_0 … τ_K ``(batch, K + 1)``, the
    flights' slopes ∂T_k/∂u_k and the law's propagation ∂u_k/∂u_{k−1} ``(batch, K)`` (None
    for a constant α), where the point is valid, and σ and s ``(batch,)``."""

    impacts: NDArray
    slopes: NDArray
    propagation: NDArray | None
    valid: NDArray
    jitter: NDArray
    scatter: NDArray

    def rows(self, index: NDArray) -> Walk:
        """The same of the rows ``index`` (a mask or indices)."""
        return Walk(self.impacts[index], self.slopes[index],
                    None if self.propagation is None else self.propagation[index],
                    self.valid[index], self.jitter[index], self.scatter[index])


@dataclass(frozen=True)
class LogPosterior:
    """Unnormalised log posterior of one model given the onsets.

    Call it with ``x`` of shape ``(batch, ndim)`` (all emcee walkers at once) or ``(ndim,)``
    (nested sampling, one point); it returns the log posterior, −inf for a parameter point
    outside the prior or one the physics forbids (never NaN, never an exception).

    Attributes
    ----------
    space
        The model's parameters.
    data
        The onsets.
    noise
        ``"gaussian"`` (T0 marginalised) or ``"student-t"`` (T0 sampled as ``t0``, or
        marginalised with the walk of a scattering restitution).
    """

    space: ParameterSpace
    data: OnsetData
    noise: str = "gaussian"

    @classmethod
    def build(cls, config: Config, model: str, data: OnsetData, noise: str = "gaussian",
              nu: Distribution | None = None) -> LogPosterior:
        """The posterior of ``model``; Student-t noise adds ``nu`` (default ν = 4) and, unless
        the restitution scatters (T0 then integrated out with the scatter's walk:
        :mod:`~drumroll.inference.scatter`), ``t0``."""
        extra: dict[str, Distribution] = {}
        if noise == "student-t":
            extra = {"nu": nu if nu is not None else Fixed(4.0)}
            if not _scatters(config.priors.get(SCATTER)):
                low, high = t0_window(data)
                extra = {"t0": Uniform(low=low, high=high), **extra}
        elif noise != "gaussian":
            raise ValueError(f"unknown noise model {noise!r}")
        return cls(ParameterSpace.build(config, model, extra), data, noise)

    def __post_init__(self) -> None:
        names = self.space.names
        object.__setattr__(self, "_jitter_column",
                           names.index("jitter") if "jitter" in names else None)
        object.__setattr__(self, "_scatter", _scatters(self.space.priors.get(SCATTER)))

    @property
    def scatters(self) -> bool:
        """Whether the restitution scatters from bounce to bounce (a dense onset covariance:
        :mod:`~drumroll.inference.scatter`)."""
        return self._scatter

    def walk(self, x: NDArray) -> Walk:
        """What the scattering restitution's walk needs, per row of ``x`` (:class:`Walk`)."""
        x = np.atleast_2d(np.asarray(x, float))
        impacts, slopes, propagation, valid = self.space.impacts_and_slopes(
            x, self.data.n_flights)
        rows = x.shape[0]
        return Walk(impacts, slopes, propagation, valid,
                    np.broadcast_to(self.space.value(x, "jitter"), rows),
                    np.broadcast_to(self.space.value(x, SCATTER), rows))

    def onset_covariance(self, x: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """Impact times τ_0 … τ_K, the onsets' covariance Σ and validity per row of ``x``
        under a scattering restitution, shapes ``(batch, K + 1)``, ``(batch, n, n)``,
        ``(batch,)``."""
        w = self.walk(x)
        with np.errstate(all="ignore"):
            covariance = onset_covariance(self.data, w.slopes, w.jitter, w.scatter,
                                          w.propagation)
        return w.impacts, covariance, w.valid

    def _scatter_marginal(self, x: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """Log-likelihood with the scatter's walk and T0 integrated out, and T0's conditional
        mean and sd, of the valid rows of ``x`` (log-likelihood −inf and T0 NaN elsewhere):
        :func:`~drumroll.inference.scatter.scatter_marginal` (Gaussian noise, exact) or
        :func:`~drumroll.inference.scatter.student_t_laplace` (Student-t, Laplace's method)."""
        x = np.atleast_2d(np.asarray(x, float))
        out = np.full((3, x.shape[0]), np.nan)
        out[0] = -np.inf
        if self.noise == "gaussian":
            w = self.walk(x)
            if w.valid.any():
                v = w.rows(w.valid)
                with np.errstate(all="ignore"):
                    out[:, w.valid] = scatter_marginal(self.data, v.impacts, v.slopes,
                                                       v.jitter, v.scatter, v.propagation)
            return out[0], out[1], out[2]
        impacts, covariance, valid = self.onset_covariance(x)
        if valid.any():
            with np.errstate(all="ignore"):
                out[:, valid] = self._student_t_scattered(self.space.values(x[valid]),
                                                          impacts[valid], covariance[valid])
        return out[0], out[1], out[2]

    def _student_t_scattered(self, values: dict[str, NDArray], impacts: NDArray,
                             covariance: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """:func:`~drumroll.inference.scatter.student_t_laplace` of rows whose parameters
        are ``values``."""
        residual, scale2 = self._student_t_parts(values, impacts)
        return student_t_laplace(residual, scatter_spread(covariance, scale2), scale2,
                                 values["nu"])

    def _student_t_parts(self, values: dict[str, NDArray], impacts: NDArray
                         ) -> tuple[NDArray, NDArray]:
        """The onsets less the noise-free impacts, and the t's squared scale per onset,
        σ² + s_i², both ``(batch, n)``, for the rows of ``values``."""
        jitter = np.broadcast_to(np.asarray(values["jitter"], float), impacts.shape[0])
        residual = self.data.times - self.data.at_onsets(impacts)
        return residual, jitter[:, None] ** 2 + self.data.sigmas**2

    def _student_t_spread(self, x: NDArray, impacts: NDArray
                          ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """What Laplace's method under Student-t noise takes for the rows of ``x`` whose
        impacts are ``impacts``: the residuals, S (the scatter's part of Σ), the t's squared
        scales and ν."""
        _, covariance, _ = self.onset_covariance(x)
        values = self.space.values(x)
        residual, scale2 = self._student_t_parts(values, impacts)
        return residual, scatter_spread(covariance, scale2), scale2, values["nu"]

    def log_likelihood(self, x: NDArray, impacts: Impacts | None = None) -> NDArray:
        """Log-likelihood per row of ``x`` (T0 marginalised for Gaussian noise and wherever the
        restitution scatters); −inf where the physics forbids the point.

        This is the lean path (:meth:`ParameterSpace.impacts` and
        :func:`~drumroll.inference.likelihood.gaussian_marginal_lean`); the general one,
        through :class:`~drumroll.physics.Bounces`, is :meth:`log_likelihood_reference`.
        ``impacts``, the rows' ``(impact times, validity)`` when the caller already has them,
        saves running the forward model again.
        """
        x = np.atleast_2d(np.asarray(x, float))
        if self._scatter:  # the slopes are needed too, so given impacts do not suffice
            return self._scatter_marginal(x)[0]
        impacts, valid = impacts or self.space.impacts(x, self.data.n_flights)
        with np.errstate(all="ignore"):
            if self.noise == "gaussian":
                i = self._jitter_column
                jitter = (x[:, i] if i is not None
                          else np.full(x.shape[0], self.space.priors["jitter"].value))
                out = gaussian_marginal_lean(self.data, impacts, jitter)
            else:
                v = self.space.values(x)
                out = student_t(self.data, impacts, v["jitter"], v["t0"], v["nu"])
        ok = valid & np.isfinite(out)
        return out if ok.all() else np.where(ok, out, -np.inf)

    def log_likelihood_one(self, x: NDArray, impacts: NDArray | None = None) -> float:
        """The log-likelihood of one point ``(ndim,)`` as a float: nested sampling's path.
        ``impacts`` (from :meth:`ParameterSpace.impacts_one`) saves recomputing them."""
        if self._scatter:
            return float(self._scatter_marginal(np.asarray(x, float)[None, :])[0][0])
        if impacts is None:
            impacts = self.space.impacts_one(x, self.data.n_flights)
        if impacts is None:
            return -math.inf
        i = self._jitter_column
        jitter = float(x[i]) if i is not None else self.space.priors["jitter"].value
        if self.noise != "gaussian":
            values = self._one_point_values(x)
            with np.errstate(all="ignore"):
                return student_t_one(self.data, impacts, jitter, values["t0"], values["nu"])
        with np.errstate(all="ignore"):
            value = float(gaussian_marginal_lean(self.data, impacts, jitter))
        return value if math.isfinite(value) else -math.inf

    def _one_point_values(self, x: NDArray) -> dict[str, float]:
        """``t0`` and ``nu`` of one point as floats (sampled or fixed)."""
        names = self.space.names
        return {name: float(x[names.index(name)]) if name in names
                else float(self.space.priors[name].value) for name in ("t0", "nu")}

    def log_likelihood_reference(self, x: NDArray) -> NDArray:
        """The log-likelihood through the full forward model (:class:`Bounces`): slower, the
        reference the lean path is tested against."""
        v = self.space.values(x)
        impacts = self.space.impact_times(v, self.data.n_flights)
        if self._scatter:
            _, covariance, _ = self.onset_covariance(x)
            if self.noise == "gaussian":
                return dense_marginal(self.data, impacts, covariance)[0]
            return self._student_t_scattered(v, impacts, covariance)[0]
        if self.noise == "gaussian":
            return gaussian_marginal(self.data, impacts, v["jitter"])[0]
        return student_t(self.data, impacts, v["jitter"], v["t0"], v["nu"])

    def __call__(self, x: NDArray, impacts: Impacts | None = None) -> NDArray | float:
        """Log posterior of one point ``(ndim,)`` (a float) or of every row of ``x``;
        ``impacts`` as in :meth:`log_likelihood`."""
        x = np.asarray(x, float)
        if x.ndim == 1:  # one point: the float path (nested sampling, optimisers)
            log_prior = self.space.log_prior_one(x)
            return log_prior + self.log_likelihood_one(x) if log_prior > -math.inf \
                else -math.inf
        out = self.space.log_prior(x)
        inside = np.isfinite(out)
        if inside.all():
            out = out + self.log_likelihood(x, impacts)
        elif inside.any():
            part = None if impacts is None else (impacts[0][inside], impacts[1][inside])
            out[inside] += self.log_likelihood(x[inside], part)
        return out

    def reference(self, x: NDArray) -> NDArray:
        """:meth:`__call__` through the general path (per-column priors, full forward model)."""
        x = np.atleast_2d(x)
        log_prior = self.space.log_prior_by_column(x)
        out = np.full(x.shape[0], -np.inf)
        inside = np.isfinite(log_prior)
        if inside.any():
            out[inside] = log_prior[inside] + self.log_likelihood_reference(x[inside])
        return np.where(np.isfinite(out), out, -np.inf)

    def conditional_t0(self, x: NDArray, rng: np.random.Generator) -> NDArray:
        """T0 per row: drawn from its conditional given the rest (exact under Gaussian noise,
        Laplace's Gaussian under Student-t noise with a scattering restitution), or read
        from ``x`` where it is sampled."""
        if self._scatter:
            _, mean, sd = self._scatter_marginal(np.atleast_2d(x))
            return mean + sd * rng.standard_normal(mean.shape)
        v = self.space.values(x)
        if self.noise != "gaussian":
            return v["t0"]
        impacts = self.space.impact_times(v, self.data.n_flights)
        _, mean, sd = gaussian_marginal(self.data, impacts, v["jitter"])
        return mean + sd * rng.standard_normal(mean.shape)

    def pointwise(self, x: NDArray, t0: NDArray) -> NDArray:
        """log p(t_k | θ, T0) per row and observed onset, shape ``(batch, n_onsets)``."""
        v = self.space.values(x)
        impacts = self.space.impact_times(v, self.data.n_flights)
        return pointwise_log_likelihood(self.data, impacts, v["jitter"], t0, self.noise,
                                        v.get("nu"))


def _scatters(prior: Distribution | None) -> bool:
    """Whether a ``restitution_scatter`` prior makes the restitution scatter (given, and not
    fixed at 0)."""
    return prior is not None and not (isinstance(prior, Fixed) and prior.value == 0.0)


def scatter_pointwise_and_noise(log_posterior: LogPosterior, x: NDArray, impacts: NDArray,
                                rng: np.random.Generator, chunk: int = 512,
                                executor: Executor | None = None,
                                idle: Callable[[], int] | None = None
                                ) -> tuple[NDArray, NDArray]:
    """LOO's conditional terms log p(t_i | t_{−i}, θ) and one draw of the onsets' noise per
    row, under a scattering restitution, in chunks of rows: under Gaussian noise along the
    roll, O(K) per row (:func:`~drumroll.inference.scatter.scatter_pointwise`,
    :func:`~drumroll.inference.scatter.scatter_noise`); under Student-t noise by Laplace's
    method from Σ (:mod:`~drumroll.inference.scatter`; the chunks keep thousands of draws of
    a long roll from holding all their n × n matrices at once).

    ``impacts`` are the rows' τ_0 … τ_K (from the full forward model). Under Student-t noise,
    a Laplace estimate per row and onset, the chunks are shared with the processes of an
    ``executor`` as they fall idle (``idle()``: how many are): each idle one is given the
    next chunk from the front, while this process takes them from the back. The terms are
    the same wherever they were computed, and the noise is drawn here, chunk by chunk, as
    without it."""
    data = log_posterior.data
    pointwise = np.empty((x.shape[0], data.n_onsets))
    noise = np.empty_like(pointwise)
    chunks = [slice(start, start + chunk) for start in range(0, x.shape[0], chunk)]
    if log_posterior.noise == "gaussian":
        for rows in chunks:
            w = log_posterior.walk(x[rows])
            pointwise[rows] = scatter_pointwise(data, impacts[rows], w.slopes, w.jitter,
                                                w.scatter, w.propagation)
            noise[rows] = scatter_noise(data, w.slopes, w.jitter, w.scatter, w.propagation, rng)
        return pointwise, noise
    given: dict[int, Future] = {}
    front, back = 0, len(chunks) - 1
    while front <= back:
        if executor is not None and idle is not None:
            running = sum(not future.done() for future in given.values())
            for _ in range(max(0, idle() - running)):
                if front >= back:  # the last one left is this process's
                    break
                given[front] = executor.submit(student_t_pointwise, log_posterior,
                                               x[chunks[front]], impacts[chunks[front]])
                front += 1
        rows = chunks[back]
        pointwise[rows] = student_t_pointwise(log_posterior, x[rows], impacts[rows])
        back -= 1
    for i, future in given.items():
        pointwise[chunks[i]] = future.result()
    for rows in chunks:  # S formed again, not kept: a long roll's would not fit at once
        _, spread, scale2, nu = log_posterior._student_t_spread(x[rows], impacts[rows])
        noise[rows] = student_t_scatter_noise(spread, scale2, nu, rng)
    return pointwise, noise


def student_t_pointwise(log_posterior: LogPosterior, x: NDArray, impacts: NDArray) -> NDArray:
    """LOO's terms under Student-t noise with a scattering restitution, per row of ``x``
    (:func:`~drumroll.inference.scatter.student_t_laplace_pointwise`); a function of its
    arguments alone, so that another process can compute a chunk of them."""
    return student_t_laplace_pointwise(*log_posterior._student_t_spread(x, impacts))
