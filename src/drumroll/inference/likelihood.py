"""The likelihood of the onset times (physics.md, "Statistical notes").

Onsets are t_k = T0 + τ_k(θ) + ε_k for the observed bounce numbers k ⊆ {0 … K}: T0 is the
first impact's time, τ_k the model's impact times after it (physics.md: τ_0 = 0,
τ_k = Σ_{j ≤ k} T_j), ε_k independent with variance σ² + s_k² (σ the jitter, s_k the
extractor's own timing uncertainty). Onset **times** are fitted, not intervals: one onset's
error enters two adjacent intervals, so interval residuals are correlated while onset-time
residuals are not. An impact that was not heard (a gap in the bounce numbers) is simply a
term that is absent: the model still runs through every flight up to K, and the onsets on
either side of the gap are compared with τ at their own k, not as one longer flight.

Every function here takes the model's impact times τ_0 … τ_K of all bounces, shape
``(batch, K + 1)``, and compares the onsets with the columns of their bounce numbers
(:meth:`OnsetData.at_onsets`).

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

from drumroll.stats import student_t_logpdf

#: Width (s) of the flat prior on T0 around the first onset.
T0_WINDOW_S = 1.0
_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True)
class OnsetData:
    """Observed onset times, their extractor uncertainties (s) and their bounce numbers.

    Attributes
    ----------
    times, sigmas
        One value per observed onset, in time order.
    bounces
        Bounce number k of each onset (``None``: 0, 1, …, N), counted from the first observed
        impact (k = 0) and strictly increasing; a missing number is an impact not heard.
    """

    times: NDArray
    sigmas: NDArray
    bounces: NDArray | None = None

    def __post_init__(self) -> None:
        times = np.asarray(self.times, float)
        bounces = (np.arange(times.size) if self.bounces is None
                   else np.asarray(self.bounces, dtype=np.intp))
        object.__setattr__(self, "bounces", bounces)
        # The columns of the model's impacts that the onsets are compared with, or None when
        # they are all of them (no gap): then no copy is made on the samplers' hot path.
        gapped = not np.array_equal(bounces, np.arange(times.size))
        object.__setattr__(self, "_at", bounces if gapped else None)
        # The extractor's uncertainty when every onset has the same one (else None): the
        # lean likelihood's fast case.
        sigmas = np.asarray(self.sigmas, float)
        equal = sigmas.size > 0 and bool(np.all(sigmas == sigmas[0]))
        object.__setattr__(self, "_equal_sigma", float(sigmas[0]) if equal else None)

    @classmethod
    def from_arrays(cls, times: ArrayLike, sigmas: ArrayLike | None = None,
                    bounces: ArrayLike | None = None) -> OnsetData:
        """Validate and store onsets; ``sigmas`` default to zero, ``bounces`` to 0, 1, …, N.

        Bounce numbers are made relative to the first onset's (which becomes k = 0): the
        first impact the microphone heard is where the model's time starts.

        Raises
        ------
        ValueError
            Arrays of different lengths, or bounce numbers that are not whole and strictly
            increasing.
        """
        times = np.asarray(times, float).ravel()
        sigmas = np.zeros_like(times) if sigmas is None else np.asarray(sigmas, float).ravel()
        sigmas = np.where(np.isfinite(sigmas), sigmas, 0.0)
        if times.shape != sigmas.shape:
            raise ValueError("times and sigmas differ in length")
        if bounces is not None:
            given = np.asarray(bounces, float).ravel()
            if given.shape != times.shape:
                raise ValueError("times and bounces differ in length")
            if not np.all(np.isfinite(given) & (given == np.round(given))):
                raise ValueError("bounce numbers must be whole numbers")
            if np.any(np.diff(given) <= 0):
                raise ValueError("bounce numbers must increase strictly with time")
            bounces = (given - given[0]).astype(np.intp) if given.size else None
        return cls(times=times, sigmas=np.maximum(sigmas, 0.0), bounces=bounces)

    @property
    def n_onsets(self) -> int:
        """Number of observed onsets."""
        return self.times.size

    @property
    def n_flights(self) -> int:
        """K, the last observed bounce number: the model runs through flights 1 … K."""
        return int(self.bounces[-1]) if self.bounces.size else -1

    @property
    def missing(self) -> list[int]:
        """Bounce numbers between 0 and K with no onset (impacts that were not heard)."""
        return [int(k) for k in np.setdiff1d(np.arange(self.n_flights + 1), self.bounces)]

    def at_onsets(self, impacts: NDArray) -> NDArray:
        """The columns of ``impacts`` (…, K + 1) at the onsets' bounce numbers, (…, n_onsets);
        ``impacts`` itself (no copy) when no bounce is missing."""
        return impacts if self._at is None else impacts[..., self._at]


def t0_marginal(chi2: NDArray, log_det: NDArray, total_weight: NDArray, n_onsets: int
                ) -> NDArray:
    """log ∫ N(t; T0 + τ, Σ) dT0 / W under T0's flat prior: −½ χ² − ½ log|Σ| − ½ log 1ᵀΣ⁻¹1
    − ½ (n − 1) log 2π − log W, with χ² the residuals' generalised least-squares misfit about
    T0's best value and 1ᵀΣ⁻¹1 its total weight (one formula for diagonal and dense Σ)."""
    return (-0.5 * chi2 - 0.5 * log_det - 0.5 * np.log(total_weight)
            - 0.5 * (n_onsets - 1) * _LOG_2PI - math.log(T0_WINDOW_S))


def gaussian_marginal(data: OnsetData, impacts: NDArray, jitter: NDArray
                      ) -> tuple[NDArray, NDArray, NDArray]:
    """Log-likelihood with T0 marginalised, and T0's conditional mean and sd.

    Parameters
    ----------
    data
        The onsets.
    impacts
        Model impact times τ_0 … τ_K after the first impact, shape ``(batch, K + 1)`` (NaN
        rows for invalid parameter points).
    jitter
        σ (s), shape ``(batch,)``.

    Returns
    -------
    log_like, t0_mean, t0_sd
        Each of shape ``(batch,)``; ``log_like`` is −inf where ``impacts`` is NaN.
    """
    residual = data.times - data.at_onsets(impacts)
    # A fixed jitter arrives as a scalar: the variances still have one row per point.
    variance = np.broadcast_to(_column(jitter) ** 2 + data.sigmas**2, residual.shape)
    weight = 1.0 / variance
    sum_w = weight.sum(axis=1)
    t0_mean = (weight * residual).sum(axis=1) / sum_w
    chi2 = (weight * (residual - t0_mean[:, None]) ** 2).sum(axis=1)
    log_like = t0_marginal(chi2, np.log(variance).sum(axis=1), sum_w, data.n_onsets)
    log_like = np.where(np.isfinite(log_like), log_like, -np.inf)
    return log_like, t0_mean, 1.0 / np.sqrt(sum_w)


def gaussian_marginal_lean(data: OnsetData, impacts: NDArray, jitter: NDArray | float
                           ) -> NDArray | float:
    """:func:`gaussian_marginal`'s log-likelihood alone, in fewer array operations.

    ``impacts`` is ``(batch, K + 1)`` with ``jitter`` ``(batch,)``, or one sequence ``(K + 1,)``
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
    residual = data.times - data.at_onsets(impacts)
    residual -= residual.sum(axis=-1, keepdims=True) * (1.0 / n)
    variance = jitter * jitter + sigma * sigma
    chi2 = np.einsum("...i,...i->...", residual, residual) / variance
    return (-0.5 * chi2 - 0.5 * (n - 1) * np.log(variance)
            - (0.5 * ((n - 1) * _LOG_2PI + math.log(n)) + math.log(T0_WINDOW_S)))


def student_t_one(data: OnsetData, impacts: NDArray, jitter: float, t0: float, nu: float
                  ) -> float:
    """:func:`student_t` for one sequence ``(K + 1,)`` with float parameters (nested sampling's
    one-point path: scalars in ``math``, one small array for the onsets)."""
    scale2 = jitter * jitter + data.sigmas * data.sigmas
    z2 = (data.times - t0 - data.at_onsets(impacts)) ** 2 / scale2
    value = float(student_t_logpdf(z2, nu, 0.5 * np.log(scale2)).sum())
    return value if math.isfinite(value) else -math.inf


def pointwise_log_likelihood(data: OnsetData, impacts: NDArray, jitter: NDArray, t0: NDArray,
                             noise: str = "gaussian", nu: NDArray | None = None) -> NDArray:
    """log p(t_k | θ, T0) for every onset, shape ``(batch, n_onsets)`` (for PSIS-LOO);
    ``impacts`` ``(batch, K + 1)``."""
    scale2 = _column(jitter) ** 2 + data.sigmas**2
    z2 = (data.times - _column(t0) - data.at_onsets(impacts)) ** 2 / scale2
    if noise == "gaussian":
        return -0.5 * (z2 + np.log(scale2) + _LOG_2PI)
    nu = _column(nu)  # a fixed ν arrives as a scalar
    return student_t_logpdf(z2, nu, 0.5 * np.log(scale2))


def _column(value: NDArray | float) -> NDArray | float:
    """A per-row parameter as a column against the onsets; a fixed (scalar) one as it is."""
    return np.asarray(value, float)[:, None] if np.ndim(value) else value


def student_t(data: OnsetData, impacts: NDArray, jitter: NDArray, t0: NDArray, nu: NDArray
              ) -> NDArray:
    """Total log-likelihood under Student-t noise (scale² = σ² + s_k²), T0 sampled."""
    total = pointwise_log_likelihood(data, impacts, jitter, t0, "student-t", nu).sum(axis=1)
    return np.where(np.isfinite(total), total, -np.inf)
