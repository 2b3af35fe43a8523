"""A model's parameter space: which parameters are sampled, and how a vector becomes physics.

emcee and dynesty see a plain array ``x`` of shape ``(batch, ndim)``; :class:`ParameterSpace`
maps its columns (plus the fixed values) onto the forward model's arguments, evaluates the
log prior and, for nested sampling, the unit-cube transform. Everything is SI inside.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from drumroll.config import Config
from drumroll.inference.priors import Fixed, LogUniform, Prior
from drumroll.parameters import MODEL_PARAMETERS, PARAMETERS
from drumroll.physics import Bounces, StickGeometry, bounce_sequence

#: Prior of the onset jitter when the config gives none (SI: 0.01 to 10 ms, scale-free).
DEFAULT_JITTER_PRIOR: Prior = LogUniform(low=1e-5, high=1e-2)

#: Stick dimensions, by the internal name under which an uncertain one is sampled.
STICK_PARAMETERS = {"stick_length": "length", "stick_tip": "tip", "stick_radius": "radius"}


@dataclass(frozen=True)
class ParameterSpace:
    """The sampled and fixed parameters of one model under one config.

    Attributes
    ----------
    model
        Forward model name.
    names
        Internal names of the sampled parameters, in column order.
    priors
        Prior of every parameter (sampled and fixed), by internal name.
    config
        The config the space was built from (stick shape, gravity).
    extra
        Names of sampled parameters that belong to the likelihood, not the physics (``t0``,
        ``nu``), appended after the physical ones.
    """

    model: str
    names: tuple[str, ...]
    priors: dict[str, Prior]
    config: Config
    extra: tuple[str, ...] = ()

    @classmethod
    def build(cls, config: Config, model: str, extra_priors: dict[str, Prior] | None = None
              ) -> ParameterSpace:
        """The space of ``model``: its physical parameters, the jitter, and ``extra_priors``."""
        priors: dict[str, Prior] = {}
        for key in MODEL_PARAMETERS[model]:
            name = PARAMETERS[key].name
            priors[name] = config.priors[name]
        priors["jitter"] = config.priors.get("jitter", DEFAULT_JITTER_PRIOR)
        if model != "powerlaw" and config.stick is not None:
            for name, field in STICK_PARAMETERS.items():
                priors[name] = getattr(config.stick, field)
        extra_priors = extra_priors or {}
        priors.update(extra_priors)
        names = tuple(n for n, p in priors.items() if not p.is_fixed and n not in extra_priors)
        extra = tuple(n for n, p in extra_priors.items() if not p.is_fixed)
        return cls(model=model, names=names + extra, priors=priors, config=config, extra=extra)

    @property
    def ndim(self) -> int:
        """Number of sampled parameters."""
        return len(self.names)

    def values(self, x: NDArray) -> dict[str, NDArray]:
        """Every parameter's value per batch row: the columns of ``x``, and the fixed ones as
        scalars (the forward model broadcasts them)."""
        x = np.atleast_2d(x)
        out: dict[str, NDArray] = {name: prior.value for name, prior in self.priors.items()
                                   if isinstance(prior, Fixed)}
        out.update({name: x[:, i] for i, name in enumerate(self.names)})
        return out

    def log_prior(self, x: NDArray) -> NDArray:
        """Sum of the sampled parameters' log densities, shape ``(batch,)``."""
        x = np.atleast_2d(x)
        total = np.zeros(x.shape[0])
        for i, name in enumerate(self.names):
            total += self.priors[name].logpdf(x[:, i])
        return total

    def prior_transform(self, u: NDArray) -> NDArray:
        """Map points of the unit cube onto the prior (nested sampling)."""
        u = np.asarray(u, float)
        return np.stack([self.priors[n].ppf(u[..., i]) for i, n in enumerate(self.names)],
                        axis=-1)

    def sample_prior(self, rng: np.random.Generator, size: int) -> NDArray:
        """``size`` independent draws from the prior, shape ``(size, ndim)``."""
        return self.prior_transform(rng.random((size, self.ndim)))

    def bounces(self, x: NDArray, n_flights: int) -> Bounces:
        """Run the forward model for every row of ``x``."""
        return self.bounces_from_values(self.values(x), n_flights)

    def bounces_from_values(self, v: dict[str, NDArray], n_flights: int) -> Bounces:
        """Run the forward model on parameter values from :meth:`values`."""
        if self.model == "powerlaw":
            return bounce_sequence("powerlaw", alpha=v["alpha"], t_b=v["t_b"],
                                   n_flights=n_flights)
        stick = StickGeometry(self.config.stick.shape, v["stick_length"], v["stick_tip"],
                              v["stick_radius"])
        return bounce_sequence(self.model, alpha=v["alpha"], n_flights=n_flights,
                               pivot=v["pivot"], height=v["height"],
                               release_speed=v["release_speed"],
                               release_angle=v["release_angle"], stick=stick,
                               g=self.config.gravity)
