"""A model's parameter space: which parameters are sampled, and how a vector becomes physics.

emcee and dynesty see a plain array ``x`` of shape ``(batch, ndim)``; :class:`ParameterSpace`
maps its columns (plus the fixed values) onto the forward model's arguments, evaluates the
log prior and, for nested sampling, the unit-cube transform. Everything is SI inside.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import ellipkinc

from drumroll.config import Config
from drumroll.inference.prior_table import PriorTable
from drumroll.inference.priors import Fixed, LogUniform, Prior
from drumroll.parameters import MODEL_PARAMETERS, PARAMETERS
from drumroll.physics import Bounces, StickGeometry, bounce_sequence
from drumroll.physics.geometry import mass_properties_squared

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

    def __post_init__(self) -> None:
        object.__setattr__(self, "_table", PriorTable(tuple(self.priors[n] for n in self.names)))
        object.__setattr__(self, "_column", {name: i for i, name in enumerate(self.names)})
        object.__setattr__(self, "_fixed", {name: float(p.value) for name, p in self.priors.items()
                                            if isinstance(p, Fixed)})
        object.__setattr__(self, "_flight_powers", {})

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
        return self._table(np.atleast_2d(np.asarray(x, float)))

    def log_prior_one(self, x: NDArray) -> float:
        """:meth:`log_prior` of one point ``(ndim,)`` as a float (plain ``math``)."""
        return self._table.log_pdf_one(np.asarray(x, float).tolist())

    def log_prior_by_column(self, x: NDArray) -> NDArray:
        """The same sum, one :meth:`Prior.logpdf` per column (the reference for tests)."""
        x = np.atleast_2d(x)
        total = np.zeros(x.shape[0])
        for i, name in enumerate(self.names):
            total += self.priors[name].logpdf(x[:, i])
        return total

    def prior_transform(self, u: NDArray) -> NDArray:
        """Map points of the unit cube onto the prior (nested sampling)."""
        return self._table.ppf(u)

    def prior_transform_by_column(self, u: NDArray) -> NDArray:
        """The same map, one :meth:`Prior.ppf` per column (the reference for tests)."""
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

    def _value(self, x: NDArray, name: str) -> NDArray | float:
        """Column ``name`` of ``x``, or its fixed value."""
        i = self._column.get(name)
        return x[:, i] if i is not None else self._fixed[name]

    def _powers(self, n_flights: int) -> NDArray:
        """k = 1 … N as floats (cached per N)."""
        k = self._flight_powers.get(n_flights)
        if k is None:
            k = self._flight_powers[n_flights] = np.arange(1.0, n_flights + 1.0)
        return k

    def impacts(self, x: NDArray, n_flights: int) -> tuple[NDArray, NDArray]:
        """Impact times τ_0 … τ_N of every row of ``x`` and where they are valid: the lean path.

        The samplers only need the impact times, not the rest of :class:`Bounces` (fall time,
        contact speed, reason codes), so this computes just those, with the formulas of
        :mod:`drumroll.physics` written for a 2-d batch with no broadcasting, masking or reason
        bookkeeping: every validity check becomes one boolean mask. Rows where the mask is
        False hold garbage (possibly NaN). Valid rows equal
        ``self.bounces(x, n_flights).impacts`` to rounding (tests/test_inference_speed_paths).

        Parameters
        ----------
        x
            Shape ``(batch, ndim)``.
        n_flights
            N.

        Returns
        -------
        impacts, valid
            Shapes ``(batch, N + 1)`` and ``(batch,)``.
        """
        k = self._powers(n_flights)
        alpha = x[:, self._column["alpha"]] if "alpha" in self._column else np.full(
            x.shape[0], self._fixed["alpha"])
        valid = (alpha > 0.0) & (alpha <= 1.0)
        with np.errstate(all="ignore"):
            if self.model == "powerlaw":
                t_b = self._value(x, "t_b")
                valid &= np.isfinite(alpha) & np.isfinite(t_b) & (t_b > 0.0)
                flights = (t_b * np.ones_like(alpha))[:, None] * alpha[:, None] ** k
            else:
                flights, valid = self._pendulum_flights(x, alpha, valid, k)
            impacts = np.zeros((x.shape[0], n_flights + 1))
            np.cumsum(flights, axis=1, out=impacts[:, 1:])
        return impacts, valid

    def _pendulum_flights(self, x: NDArray, alpha: NDArray, valid: NDArray, k: NDArray
                          ) -> tuple[NDArray, NDArray]:
        """Flights T_1 … T_N of the small-angle or exact pendulum (physics.release, .pendulum,
        .small_angle and .geometry, inlined)."""
        v = self._value
        d, h = v(x, "pivot"), v(x, "height")
        l1 = v(x, "stick_length")
        v0, theta0 = v(x, "release_speed"), v(x, "release_angle")
        total_length, centre_of_mass, k_o_squared = mass_properties_squared(
            self.config.stick.shape, l1, v(x, "stick_tip"), v(x, "stick_radius"), d)
        arm = total_length - d
        finite = alpha + d + h + v0 + theta0 + total_length + centre_of_mass + k_o_squared
        valid = (valid & np.isfinite(finite) & (d >= 0.0) & (d < centre_of_mass) & (h > 0.0)
                 & (h < arm) & (np.abs(theta0) < 0.5 * np.pi) & (v0 >= 0.0))
        gamma = self.config.gravity * (centre_of_mass - d) / k_o_squared
        sin_theta_c = h / arm
        omega0 = v0 / arm
        if self.model == "small-angle":
            theta_c = sin_theta_c
            valid &= theta0 < theta_c
            omega_c = np.sqrt(omega0**2 + 2.0 * gamma * (theta_c - theta0))
            t_b = 2.0 * omega_c / gamma
            return (t_b * np.ones_like(alpha))[:, None] * alpha[:, None] ** k, valid
        theta_c = np.arcsin(sin_theta_c)
        valid &= theta0 < theta_c
        half_psi_0 = 0.25 * np.pi - 0.5 * theta0
        half_psi_c = 0.25 * np.pi - 0.5 * theta_c
        cos_half_c = np.cos(half_psi_c)
        s_c, c_c = np.sin(half_psi_c) ** 2, cos_half_c * cos_half_c
        drop = np.sin(half_psi_0 - half_psi_c) * np.sin(half_psi_0 + half_psi_c)
        contact_excess = drop + omega0**2 / (4.0 * gamma)
        excess = contact_excess[:, None] * alpha[:, None] ** (2.0 * k)
        c_c = c_c[:, None]
        if k.size:  # α ≤ 1: the first flight rises highest, so it alone can go over the top
            valid &= c_c[:, 0] - excess[:, 0] > 0.0
        m = s_c[:, None] + excess
        sin2_chi = np.minimum(excess / (m * c_c), 1.0)
        phase = ellipkinc(np.arcsin(np.sqrt(sin2_chi)), m)
        return phase * (2.0 / np.sqrt(gamma))[:, None], valid

    def impacts_one(self, x: NDArray, n_flights: int) -> NDArray | None:
        """:meth:`impacts` for a single point (nested sampling): ``None`` where it is invalid.

        The per-point quantities (geometry, γ, θ_C, the contact energy) are Python floats
        (``math``), a few tens of nanoseconds per operation instead of a microsecond per numpy
        call; only the N flights are arrays. Same formulas as :meth:`impacts`, and tested
        against the full forward model like it.
        """
        value = self.value_of(x.tolist())
        alpha = value("alpha")
        if not 0.0 < alpha <= 1.0:
            return None
        k = self._powers(n_flights)
        if self.model == "powerlaw":
            t_b = value("t_b")
            if not (math.isfinite(t_b) and t_b > 0.0):
                return None
            flights = t_b * alpha**k
        else:
            flights = self._pendulum_flights_one(value, alpha, k)
            if flights is None:
                return None
        impacts = np.zeros(n_flights + 1)
        np.cumsum(flights, out=impacts[1:])
        return impacts

    def value_of(self, row: list[float]) -> Callable[[str], float]:
        """A parameter's value by name for one point ``row`` (sampled or fixed), as a float."""
        col, fixed = self._column, self._fixed

        def value(name: str) -> float:
            i = col.get(name)
            return row[i] if i is not None else fixed[name]

        return value

    def stick_one(self, value: Callable[[str], float]) -> tuple[float, float, float] | None:
        """Total length, centre of mass and k_O² (eqs. 12–16) of one point's stick about its
        pivot, as floats; ``value`` gives a parameter's value by name. ``None`` for a stick
        with no positive mass."""
        d, l1 = value("pivot"), value("stick_length")
        if self.config.stick.shape == "thin-rod":
            return l1, 0.5 * l1, l1 * l1 / 3.0 + d * d - l1 * d
        l2, r = value("stick_tip"), value("stick_radius")
        weight = 3.0 * l1 + l2
        if not (math.isfinite(weight) and weight > 0.0):
            return None
        cylinder = 3.0 * l1 * (0.25 * (r * r + l1 * l1 / 3.0) + (0.5 * l1 - d) ** 2)
        cone = l2 * (3.0 / 80.0 * (4.0 * r * r + l2 * l2) + (l1 - d + 0.25 * l2) ** 2)
        return (l1 + l2, (6.0 * l1 * l1 + l2 * (4.0 * l1 + l2)) / (4.0 * weight),
                (cylinder + cone) / weight)

    def _pendulum_flights_one(self, value, alpha: float, k: NDArray) -> NDArray | None:
        """Flights of one point of a pendulum model, or ``None`` where it is invalid."""
        d, h = value("pivot"), value("height")
        v0, theta0 = value("release_speed"), value("release_angle")
        stick = self.stick_one(value)
        if stick is None:
            return None
        total_length, centre_of_mass, k_o_squared = stick
        arm = total_length - d
        if not (math.isfinite(alpha + d + h + v0 + theta0 + total_length + centre_of_mass
                              + k_o_squared)
                and 0.0 <= d < centre_of_mass and 0.0 < h < arm
                and abs(theta0) < 0.5 * math.pi and v0 >= 0.0 and k_o_squared > 0.0):
            return None
        gamma = self.config.gravity * (centre_of_mass - d) / k_o_squared
        sin_theta_c = h / arm
        omega0 = v0 / arm
        if self.model == "small-angle":
            if not theta0 < sin_theta_c:
                return None
            t_b = 2.0 * math.sqrt(omega0 * omega0 + 2.0 * gamma * (sin_theta_c - theta0)) / gamma
            return t_b * alpha**k
        theta_c = math.asin(sin_theta_c)
        if not theta0 < theta_c:
            return None
        half_psi_0 = 0.25 * math.pi - 0.5 * theta0
        half_psi_c = 0.25 * math.pi - 0.5 * theta_c
        s_c, c_c = math.sin(half_psi_c) ** 2, math.cos(half_psi_c) ** 2
        drop = math.sin(half_psi_0 - half_psi_c) * math.sin(half_psi_0 + half_psi_c)
        contact_excess = drop + omega0 * omega0 / (4.0 * gamma)
        if k.size and not c_c - contact_excess * alpha * alpha > 0.0:
            return None  # the first rebound goes over the top
        excess = contact_excess * alpha ** (2.0 * k)
        m = s_c + excess
        sin2_chi = np.minimum(excess / (m * c_c), 1.0)
        return ellipkinc(np.arcsin(np.sqrt(sin2_chi)), m) * (2.0 / math.sqrt(gamma))
