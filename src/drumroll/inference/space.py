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
from drumroll.distributions import Distribution, Fixed, LogNormal, LogUniform, OrZero, Uniform
from drumroll.inference.prior_predictive import propagate
from drumroll.inference.prior_table import PriorTable
from drumroll.physics import Bounces, StickGeometry
from drumroll.physics.contact import CONTACT_LAWS, contact_delays
from drumroll.physics.model import alpha_of
from drumroll.physics.models import forward_model
from drumroll.physics.release import rim_strikes_first, tip_contact_only
from drumroll.quantities import STICK_DIMENSIONS

#: Distribution of the onset jitter when the config gives none (SI: 0.01 to 10 ms, scale-free).
DEFAULT_JITTER_PRIOR: Distribution = LogUniform(low=1e-5, high=1e-2)

#: The restitution's bounce-to-bounce scatter (:mod:`drumroll.inference.scatter`), a
#: parameter of the noise of every model when the config gives it a prior.
SCATTER = "restitution_scatter"

#: The contact time of each impact: the onset marks the start of contact, the next flight
#: starts at its end, so impact m comes m contact times later than the flights alone put it.
CONTACT = "contact"

#: Distribution of the contact time when the config gives none (SI): none at all or 0 to 3 ms,
#: at even odds. A drumstick rests on a head for about a millisecond, a ball on a table for
#: less (physics.md), so a roll is timed from the starts of contact and every model carries
#: it unless the config fixes it (``contact_ms = 0``); but a roll cannot tell no contact from
#: a fraction of a millisecond, and a range starting at 0 would then put its mean inside the
#: range and pull α and t_B along (:class:`~drumroll.distributions.OrZero`).
DEFAULT_CONTACT_PRIOR: Distribution = OrZero(Uniform(low=0.0, high=3e-3), p_zero=0.5)

#: Stick dimensions: the internal name under which an uncertain one is sampled → its field.
STICK_PARAMETERS = {q.name: q.field for q in STICK_DIMENSIONS.values()}


#: Draws of the geometry's prior predictive behind a default t_B prior (its lognormal's mu and
#: sigma then carry ~0.5 % Monte Carlo error), and their seed (the same prior every run).
PREDICTIVE_DRAWS, PREDICTIVE_SEED = 20_000, 0


def default_prior(config: Config, name: str) -> Distribution:
    """The prior of a parameter the config leaves to the set-up: the power law's t_B when a
    ``[stick]`` is given is the exact pendulum's prior predictive of t_B (what ``drumroll
    predict`` gives), as a lognormal with the draws' mean and sd of ln t_B. A flat range would
    make the power law's Bayes factor a statement about that range's width (issue 13)."""
    if name != "t_b" or config.stick is None:
        raise KeyError(name)
    t_b = propagate(config, "pendulum", n_flights=0, n_draws=PREDICTIVE_DRAWS,
                    seed=PREDICTIVE_SEED).bounces.t_b
    log_t_b = np.log(t_b[np.isfinite(t_b)])
    return LogNormal(mu=float(np.mean(log_t_b)), sigma=float(np.std(log_t_b, ddof=1)))


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
        Distribution of every parameter (sampled and fixed), by internal name.
    config
        The config the space was built from (stick shape, gravity).
    extra
        Names of sampled parameters that belong to the likelihood, not the physics (``t0``,
        ``nu``), appended after the physical ones.
    """

    model: str
    names: tuple[str, ...]
    priors: dict[str, Distribution]
    config: Config
    extra: tuple[str, ...] = ()

    @classmethod
    def build(cls, config: Config, model: str, extra_priors: dict[str, Distribution] | None = None
              ) -> ParameterSpace:
        """The space of ``model``: its physical parameters, the jitter, and ``extra_priors``."""
        forward = forward_model(model)
        priors: dict[str, Distribution] = {
            name: config.priors[name] if name in config.priors else default_prior(config, name)
            for name in forward.parameters}
        priors["jitter"] = config.priors.get("jitter", DEFAULT_JITTER_PRIOR)
        # Parts of every model: the contact time always, the scatter when the config asks.
        priors[CONTACT] = config.priors.get(CONTACT, DEFAULT_CONTACT_PRIOR)
        if SCATTER in config.priors:
            priors[SCATTER] = config.priors[SCATTER]
        if forward.needs_stick and config.stick is not None:
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
        # Columns sampled through a coordinate that is not the parameter itself (an atom at 0).
        object.__setattr__(self, "_mapped", {name: p.parameter_of for name, p in
                                             self.priors.items() if isinstance(p, OrZero)})
        forward = forward_model(self.model)
        object.__setattr__(self, "forward", forward)
        object.__setattr__(self, "_stick_shape",
                           self.config.stick.shape if forward.needs_stick else None)
        needed = (*forward.parameters, *(STICK_PARAMETERS if forward.needs_stick else ()))
        object.__setattr__(self, "_kernel_fixed",
                           tuple(n for n in needed if n not in self._column))

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
        for name, parameter_of in self._mapped.items():
            out[name] = parameter_of(out[name])
        return out

    def log_prior(self, x: NDArray) -> NDArray:
        """Sum of the sampled parameters' log densities, shape ``(batch,)``."""
        return self._table(np.atleast_2d(np.asarray(x, float)))

    def log_prior_one(self, x: NDArray) -> float:
        """:meth:`log_prior` of one point ``(ndim,)`` as a float (plain ``math``)."""
        return self._table.log_pdf_one(np.asarray(x, float).tolist())

    def log_prior_by_column(self, x: NDArray) -> NDArray:
        """The same sum, one :meth:`Distribution.logpdf` per column (the reference for tests)."""
        x = np.atleast_2d(x)
        total = np.zeros(x.shape[0])
        for i, name in enumerate(self.names):
            total += self.priors[name].logpdf(x[:, i])
        return total

    def prior_transform(self, u: NDArray) -> NDArray:
        """Map points of the unit cube onto the prior (nested sampling)."""
        return self._table.ppf(u)

    def prior_transform_by_column(self, u: NDArray) -> NDArray:
        """The same map, one :meth:`Distribution.ppf` per column (the reference for tests)."""
        u = np.asarray(u, float)
        return np.stack([self.priors[n].ppf(u[..., i]) for i, n in enumerate(self.names)],
                        axis=-1)

    def sample_prior(self, rng: np.random.Generator, size: int) -> NDArray:
        """``size`` independent draws from the prior, shape ``(size, ndim)``."""
        return self.prior_transform(rng.random((size, self.ndim)))

    def bounces(self, x: NDArray, n_flights: int) -> Bounces:
        """Run the forward model for every row of ``x``."""
        return self.bounces_from_values(self.values(x), n_flights)

    def impact_times(self, v: dict[str, NDArray], n_flights: int) -> NDArray:
        """Impact times τ_0 … τ_N after the first impact through the full forward model
        (:meth:`bounces_from_values`), contact times included; NaN rows where invalid."""
        bounces = self.bounces_from_values(v, n_flights)
        return self.with_contact(bounces.impacts, v.get(CONTACT), bounces.speed_ratios)

    @property
    def contact_law(self) -> str:
        """``[likelihood] contact``: how the contact time changes with the impact speed
        (:mod:`drumroll.physics.contact`)."""
        return self.config.section("likelihood", {}).get("contact", CONTACT_LAWS[0])

    def with_contact(self, impacts: NDArray, contact: NDArray | float | None,
                     speed_ratios: NDArray | None = None) -> NDArray:
        """The impacts delayed by every earlier impact's contact time (physics.md): m τ_c,
        or under the Hertzian law each τ_j scaled by the impact's speed (``speed_ratios``
        r_1 … r_N, needed then)."""
        if contact is None:
            return impacts
        hertz = self.contact_law == "hertz"
        with np.errstate(invalid="ignore", over="ignore"):  # a row outside the prior: NaN
            return impacts + contact_delays(contact, impacts.shape[-1],
                                            speed_ratios if hertz else None)

    def _speed_ratios(self, values: dict[str, NDArray | float], n_flights: int
                      ) -> NDArray | None:
        """r_1 … r_N of the sampler's rows where the Hertzian contact law needs them."""
        if CONTACT not in self.priors or self.contact_law != "hertz":
            return None
        return self.forward.law.speed_ratios(alpha_of(values), values, n_flights)[0]

    def bounces_from_values(self, v: dict[str, NDArray], n_flights: int) -> Bounces:
        """Run the forward model on parameter values from :meth:`values`."""
        stick = None
        if self.forward.needs_stick:
            stick = StickGeometry(self.config.stick.shape, v["stick_length"], v["stick_tip"],
                                  v["stick_radius"])
        bounces = self.forward.bounces(v, n_flights, stick, self.config.gravity)
        return (tip_contact_only(bounces, stick, v["pivot"], v["height"])
                if self.forward.needs_stick else bounces)

    def impacts(self, x: NDArray, n_flights: int) -> tuple[NDArray, NDArray]:
        """Impact times τ_0 … τ_N of every row of ``x`` and where they are valid: the model's
        sampler kernel (:meth:`~drumroll.physics.model.ForwardModel.flights`), which computes
        only the flights, with one validity mask instead of a reason per point. Rows where the
        mask is False hold garbage (possibly NaN). Valid rows equal
        ``self.bounces(x, n_flights).impacts`` (tests/unit/inference/test_posterior.py).

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
        x = np.atleast_2d(x)
        values = self._kernel_values(x)
        impacts, valid = self.forward.impacts(values, n_flights, self._stick_shape,
                                              self.config.gravity)
        valid = valid & self._tip_first(values)
        if impacts.shape[0] != x.shape[0]:  # every physical parameter fixed
            impacts = np.broadcast_to(impacts, (x.shape[0], n_flights + 1))
            valid = np.broadcast_to(valid, (x.shape[0],))
        if CONTACT in self.priors:
            impacts = self.with_contact(impacts, self.value(x, CONTACT),
                                        self._speed_ratios(values, n_flights))
        return impacts, valid

    def impacts_and_slopes(self, x: NDArray, n_flights: int
                           ) -> tuple[NDArray, NDArray, NDArray | None, NDArray]:
        """:meth:`impacts`, the flights' slopes ∂T_k/∂u_k and the restitution law's
        propagation ∂u_k/∂u_{k−1} (None for a constant α)
        (:meth:`~drumroll.physics.model.ForwardModel.restitution_slopes`), shape
        ``(batch, N)``: what a scattering restitution needs."""
        x = np.atleast_2d(x)
        values = self._kernel_values(x)
        flights, slopes, propagation, valid = self.forward.restitution_slopes(
            values, n_flights, self._stick_shape, self.config.gravity)
        valid = valid & self._tip_first(values)
        shape = (x.shape[0], n_flights)
        flights, slopes = np.broadcast_to(flights, shape), np.broadcast_to(slopes, shape)
        if propagation is not None:
            propagation = np.broadcast_to(propagation, shape)
        impacts = np.zeros((x.shape[0], n_flights + 1))
        np.cumsum(flights, axis=1, out=impacts[:, 1:])
        if CONTACT in self.priors:
            impacts = self.with_contact(impacts, self.value(x, CONTACT),
                                        self._speed_ratios(values, n_flights))
        return impacts, slopes, propagation, np.broadcast_to(valid, shape[:1])

    def _tip_first(self, values: dict[str, NDArray | float]) -> NDArray | bool:
        """Where the tip, not the rim of its cone, strikes first (every model assumes it:
        :func:`~drumroll.physics.release.tip_strikes_first`)."""
        if not self.forward.needs_stick or self._stick_shape == "thin-rod":
            return True
        return ~rim_strikes_first(self._stick_shape, values["stick_length"],
                                  values["stick_tip"], values["stick_radius"], values["pivot"],
                                  values["height"])

    def _kernel_values(self, x: NDArray) -> dict[str, NDArray | float]:
        """The forward kernel's arguments for the rows of ``x``: columns and fixed values."""
        values: dict[str, NDArray | float] = {name: x[:, i] for name, i in self._column.items()}
        values.update((name, self._fixed[name]) for name in self._kernel_fixed)
        return values

    def value(self, x: NDArray, name: str) -> NDArray | float:
        """Column ``name`` of ``x`` (shape ``(batch, ndim)``), or its fixed value."""
        i = self._column.get(name)
        if i is None:
            return self._fixed[name]
        return self._mapped[name](x[:, i]) if name in self._mapped else x[:, i]

    def impacts_one(self, x: NDArray, n_flights: int) -> NDArray | None:
        """:meth:`impacts` for a single point ``(ndim,)`` (nested sampling): ``None`` where it
        is invalid."""
        impacts, valid = self.impacts(np.asarray(x, float)[None, :], n_flights)
        return impacts[0] if valid[0] else None
