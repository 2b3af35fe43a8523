"""The likelihood of the onset times (physics.md, "Statistical notes").

Onsets are t_k = T0 + τ_k(θ) + ε_k, k = 0 … N: T0 is the first impact's time, τ_k the
model's impact times after it, ε_k independent with variance σ² + s_k² (σ the jitter, s_k
the extractor's own timing uncertainty). Onset **times** are fitted, not intervals: one
onset's error enters two adjacent intervals, so interval residuals are correlated while
onset-time residuals are not.

With Gaussian noise T0 enters linearly and is marginalised analytically under a flat prior
over a window of :data:`T0_WINDOW_S` (the window's width is a constant that cancels in every
comparison between models); its exact conditional posterior, a normal distribution, is then
sampled afterwards for the pointwise log-likelihood. With Student-t noise T0 is sampled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

#: Width (s) of the flat prior on T0 around the first onset.
T0_WINDOW_S = 1.0
_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True)
class OnsetData:
    """Observed onset times and their extractor uncertainties (s)."""

    times: NDArray
    sigmas: NDArray

    def __post_init__(self) -> None:
        # The extractor's uncertainty when every onset has the same one (else None): the
        # lean likelihood's fast case.
        sigmas = np.asarray(self.sigmas, float)
        equal = sigmas.size > 0 and bool(np.all(sigmas == sigmas[0]))
        object.__setattr__(self, "_equal_sigma", float(sigmas[0]) if equal else None)

    @classmethod
    def from_arrays(cls, times: ArrayLike, sigmas: ArrayLike | None = None) -> OnsetData:
        """Validate and store onsets; ``sigmas`` default to zero."""
        times = np.asarray(times, float).ravel()
        sigmas = np.zeros_like(times) if sigmas is None else np.asarray(sigmas, float).ravel()
        sigmas = np.where(np.isfinite(sigmas), sigmas, 0.0)
        if times.shape != sigmas.shape:
            raise ValueError("times and sigmas differ in length")
        return cls(times=times, sigmas=np.maximum(sigmas, 0.0))

    @property
    def n_onsets(self) -> int:
        return self.times.size

    @property
    def n_flights(self) -> int:
        return self.times.size - 1


def gaussian_marginal(data: OnsetData, impacts: NDArray, jitter: NDArray
                      ) -> tuple[NDArray, NDArray, NDArray]:
    """Log-likelihood with T0 marginalised, and T0's conditional mean and sd.

    Parameters
    ----------
    data
        The onsets.
    impacts
        Model impact times after the first impact, shape ``(batch, N + 1)`` (NaN rows for
        invalid parameter points).
    jitter
        σ (s), shape ``(batch,)``.

    Returns
    -------
    log_like, t0_mean, t0_sd
        Each of shape ``(batch,)``; ``log_like`` is −inf where ``impacts`` is NaN.
    """
    variance = _column(jitter) ** 2 + data.sigmas**2
    weight = 1.0 / variance
    residual = data.times - impacts
    sum_w = weight.sum(axis=1)
    t0_mean = (weight * residual).sum(axis=1) / sum_w
    chi2 = (weight * (residual - t0_mean[:, None]) ** 2).sum(axis=1)
    log_like = (-0.5 * chi2 - 0.5 * np.log(variance).sum(axis=1)
                - 0.5 * (data.n_onsets - 1) * _LOG_2PI - 0.5 * np.log(sum_w)
                - math.log(T0_WINDOW_S))
    log_like = np.where(np.isfinite(log_like), log_like, -np.inf)
    return log_like, t0_mean, 1.0 / np.sqrt(sum_w)


def gaussian_marginal_lean(data: OnsetData, impacts: NDArray, jitter: NDArray | float
                           ) -> NDArray | float:
    """:func:`gaussian_marginal`'s log-likelihood alone, in fewer array operations.

    ``impacts`` is ``(batch, N + 1)`` with ``jitter`` ``(batch,)``, or one sequence ``(N + 1,)``
    with a float ``jitter``. When every onset has the same extractor uncertainty (the usual
    case, e.g. all zero) the weights are equal within a row, so T0's conditional mean is the
    plain mean of the residuals and the weights factor out of the sums. Non-finite results
    are not cleaned up: the caller masks invalid rows.
    """
    sigma = data._equal_sigma
    if sigma is None:
        if np.ndim(impacts) == 1:
            return float(gaussian_marginal(data, impacts[None, :], np.atleast_1d(jitter))[0][0])
        return gaussian_marginal(data, impacts, jitter)[0]
    n = data.n_onsets
    residual = data.times - impacts
    residual -= residual.sum(axis=-1, keepdims=True) * (1.0 / n)
    variance = jitter * jitter + sigma * sigma
    chi2 = np.einsum("...i,...i->...", residual, residual) / variance
    return (-0.5 * chi2 - 0.5 * (n - 1) * np.log(variance)
            - (0.5 * ((n - 1) * _LOG_2PI + math.log(n)) + math.log(T0_WINDOW_S)))


def student_t_one(data: OnsetData, impacts: NDArray, jitter: float, t0: float, nu: float
                  ) -> float:
    """:func:`student_t` for one sequence ``(N + 1,)`` with float parameters (nested sampling's
    one-point path: scalars in ``math``, one small array for the onsets)."""
    scale2 = jitter * jitter + data.sigmas * data.sigmas
    z2 = (data.times - t0 - impacts) ** 2 / scale2
    n = data.n_onsets
    value = (n * (math.lgamma(0.5 * (nu + 1.0)) - math.lgamma(0.5 * nu)
                  - 0.5 * math.log(nu * math.pi))
             - 0.5 * float(np.log(scale2).sum())
             - 0.5 * (nu + 1.0) * float(np.log1p(z2 * (1.0 / nu)).sum()))
    return value if math.isfinite(value) else -math.inf


def pointwise_log_likelihood(data: OnsetData, impacts: NDArray, jitter: NDArray, t0: NDArray,
                             noise: str = "gaussian", nu: NDArray | None = None) -> NDArray:
    """log p(t_k | θ, T0) for every onset, shape ``(batch, N + 1)`` (for PSIS-LOO)."""
    scale2 = _column(jitter) ** 2 + data.sigmas**2
    z2 = (data.times - _column(t0) - impacts) ** 2 / scale2
    if noise == "gaussian":
        return -0.5 * (z2 + np.log(scale2) + _LOG_2PI)
    nu = _column(nu)  # a fixed ν arrives as a scalar
    return (special.gammaln(0.5 * (nu + 1.0)) - special.gammaln(0.5 * nu)
            - 0.5 * np.log(nu * math.pi * scale2) - 0.5 * (nu + 1.0) * np.log1p(z2 / nu))


def _column(value: NDArray | float) -> NDArray | float:
    """A per-row parameter as a column against the onsets; a fixed (scalar) one as it is."""
    return np.asarray(value, float)[:, None] if np.ndim(value) else value


def student_t(data: OnsetData, impacts: NDArray, jitter: NDArray, t0: NDArray, nu: NDArray
              ) -> NDArray:
    """Total log-likelihood under Student-t noise (scale² = σ² + s_k²), T0 sampled."""
    total = pointwise_log_likelihood(data, impacts, jitter, t0, "student-t", nu).sum(axis=1)
    return np.where(np.isfinite(total), total, -np.inf)
