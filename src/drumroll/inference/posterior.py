"""The log posterior that the samplers call: prior + likelihood, vectorised over walkers."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from drumroll.config import Config
from drumroll.inference.likelihood import (
    T0_WINDOW_S,
    OnsetData,
    gaussian_marginal,
    pointwise_log_likelihood,
    student_t,
)
from drumroll.inference.priors import Fixed, Prior, Uniform
from drumroll.inference.space import ParameterSpace

NOISE_MODELS = ("gaussian", "student-t")


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
        ``"gaussian"`` (T0 marginalised) or ``"student-t"`` (T0 sampled as ``t0``).
    """

    space: ParameterSpace
    data: OnsetData
    noise: str = "gaussian"

    @classmethod
    def build(cls, config: Config, model: str, data: OnsetData, noise: str = "gaussian",
              nu: Prior | None = None) -> LogPosterior:
        """The posterior of ``model``; Student-t noise adds ``t0`` and ``nu`` (default ν = 4)."""
        extra: dict[str, Prior] = {}
        if noise == "student-t":
            first = float(data.times[0])
            extra = {"t0": Uniform(low=first - 0.5 * T0_WINDOW_S, high=first + 0.5 * T0_WINDOW_S),
                     "nu": nu if nu is not None else Fixed(4.0)}
        elif noise != "gaussian":
            raise ValueError(f"unknown noise model {noise!r}")
        return cls(ParameterSpace.build(config, model, extra), data, noise)

    def log_likelihood(self, x: NDArray) -> NDArray:
        """Log-likelihood per row of ``x`` (T0 marginalised for Gaussian noise)."""
        v = self.space.values(x)
        impacts = self.space.bounces_from_values(v, self.data.n_flights).impacts
        if self.noise == "gaussian":
            return gaussian_marginal(self.data, impacts, v["jitter"])[0]
        return student_t(self.data, impacts, v["jitter"], v["t0"], v["nu"])

    def __call__(self, x: NDArray) -> NDArray | float:
        single = np.ndim(x) == 1
        x = np.atleast_2d(x)
        log_prior = self.space.log_prior(x)
        out = np.full(x.shape[0], -np.inf)
        inside = np.isfinite(log_prior)
        if inside.any():
            out[inside] = log_prior[inside] + self.log_likelihood(x[inside])
        return float(out[0]) if single else out

    def conditional_t0(self, x: NDArray, rng: np.random.Generator) -> NDArray:
        """T0 per row: sampled from its exact conditional (Gaussian) or read from ``x``."""
        v = self.space.values(x)
        if self.noise != "gaussian":
            return v["t0"]
        impacts = self.space.bounces_from_values(v, self.data.n_flights).impacts
        _, mean, sd = gaussian_marginal(self.data, impacts, v["jitter"])
        return mean + sd * rng.standard_normal(mean.shape)

    def pointwise(self, x: NDArray, t0: NDArray) -> NDArray:
        """log p(t_k | θ, T0) per row and onset, shape ``(batch, N + 1)``."""
        v = self.space.values(x)
        impacts = self.space.bounces_from_values(v, self.data.n_flights).impacts
        return pointwise_log_likelihood(self.data, impacts, v["jitter"], t0, self.noise,
                                        v.get("nu"))
