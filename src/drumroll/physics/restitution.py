"""Restitution laws: how the rebound speed after each impact follows from the impact speed.

Every model here loses speed only at the impacts (energy is conserved in flight, so a flight
lands as fast as it left). After k impacts the rebound speed is the first contact speed v₁
times r_k = α_1 ⋯ α_k, and a model's flights depend on the restitution only through these
ratios (physics.md). A law is what gives them:

* ``constant`` (eq. 9): α_k = α for every impact, r_k = α^k;
* ``speed``: 1 − α(v) = (1 − α) (v / v₁)^p, so ``alpha`` stays the restitution of the first
  impact and the exponent ``p`` (``restitution_exponent``) says how it changes as the bouncer
  slows. p = 0 is the constant law; viscoelastic contact theory gives p = 1/5 (the loss grows
  as v^{1/5}); a light ball, whose air drag grows with speed, shows a larger effective p.
  Impact k + 1 arrives with the speed impact k sent it off with, v_{k+1} / v₁ = r_k, so

      r_{k+1} = r_k α(v₁ r_k) = r_k [1 − (1 − α) r_k^p],

  a recursion that the samplers run for a whole batch of walkers at once. (For the power
  law, whose flights are proportional to the rebound speeds, v is read as the flight time;
  the same ratios follow.)

A law also gives ∂ ln r_k / ∂ ln r_{k−1}, which carries a bounce-to-bounce scatter of the
restitution through the later impacts (:mod:`drumroll.inference.scatter`). A point is a
possible bouncer only where every α_k lies in (0, 1] and the rebound speed grows with the
impact speed (that derivative is positive): a harder impact never rebounds slower.

Adding a law is one subclass and one line in :data:`LAWS`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Parameter values by internal name (SI): arrays of one batch shape, or scalars.
Values = Mapping[str, ArrayLike]

#: The speed law's exponent, by internal name (its config key is the same).
EXPONENT = "restitution_exponent"


class RestitutionLaw(ABC):
    """How α depends on the impact (see the module docstring).

    Attributes
    ----------
    name
        The law's name after the slash in a model's name (``pendulum/speed``).
    parameters
        Internal names of the law's own parameters, besides ``alpha``.
    title
        In words, for verdicts and legends.
    """

    name: ClassVar[str]
    parameters: ClassVar[tuple[str, ...]] = ()
    title: ClassVar[str]

    @abstractmethod
    def speed_ratios(self, alpha: NDArray, values: Values, n_flights: int
                     ) -> tuple[NDArray, NDArray]:
        """r_k = α_1 ⋯ α_k, the rebound speed after k impacts over the first contact speed.

        Parameters
        ----------
        alpha
            α of the first impact, shape ``(batch,)``.
        values
            The law's own parameters by internal name (arrays ``(batch,)`` or scalars).
        n_flights
            N.

        Returns
        -------
        ratios, valid
            Shapes ``(batch, N)`` and ``(batch,)``: where every α_k is a restitution and the
            rebound speed grows with the impact speed. Invalid rows hold finite garbage.
        """

    @abstractmethod
    def restitution(self, alpha: NDArray, values: Values, ratio: NDArray) -> NDArray:
        """α of an impact that comes in at ``ratio`` times the first contact speed, shape
        ``(batch,)``: the step r_k = r_{k−1} α(v₁ r_{k−1}) of :meth:`speed_ratios`, for a
        caller that carries the speeds itself (a restitution that also scatters from bounce to
        bounce, simulated impact by impact: :mod:`drumroll.calibration.roll`)."""

    @abstractmethod
    def propagation(self, alpha: NDArray, values: Values, ratios: NDArray) -> NDArray | None:
        """∂ ln r_k / ∂ ln r_{k−1} for k = 1 … N, shape ``(batch, N)``: how a change of the
        rebound speed before impact k carries into the rebound after it. ``None`` where it is
        1 everywhere (the constant law)."""


class Constant(RestitutionLaw):
    """α_k = α (eq. 9): r_k = α^k."""

    name = "constant"
    title = "constant restitution"

    def speed_ratios(self, alpha: NDArray, values: Values, n_flights: int
                     ) -> tuple[NDArray, NDArray]:
        ratios = alpha[:, None] ** np.arange(1.0, n_flights + 1.0)
        return ratios, np.ones(alpha.shape, dtype=bool)

    def restitution(self, alpha: NDArray, values: Values, ratio: NDArray) -> NDArray:
        ratio = np.asarray(ratio, float)
        return np.broadcast_to(_per_row(alpha, alpha.shape, ratio), ratio.shape).astype(float)

    def propagation(self, alpha: NDArray, values: Values, ratios: NDArray) -> None:
        return None


class SpeedDependent(RestitutionLaw):
    """1 − α(v) = (1 − α)(v / v₁)^p (the module docstring)."""

    name = "speed"
    parameters = (EXPONENT,)
    title = "speed-dependent restitution"

    def speed_ratios(self, alpha: NDArray, values: Values, n_flights: int
                     ) -> tuple[NDArray, NDArray]:
        exponent = _column(values[EXPONENT], alpha.shape)
        ratios = np.empty((alpha.size, n_flights))
        valid = np.ones(alpha.shape, dtype=bool)
        ratio = np.ones_like(alpha)  # r_0: the first impact comes at the full contact speed
        with np.errstate(all="ignore"):
            for k in range(n_flights):
                restitution = self.restitution(alpha, values, ratio)
                # d ln r_k / d ln r_{k−1} = 1 − p (1 − α_k) / α_k > 0: a harder impact
                # rebounds faster (module docstring).
                valid &= ((restitution > 0.0) & (restitution <= 1.0)
                          & (restitution > exponent * (1.0 - restitution)))
                ratio = ratio * np.where(valid, restitution, 0.5)
                ratios[:, k] = ratio
        return ratios, valid

    def restitution(self, alpha: NDArray, values: Values, ratio: NDArray) -> NDArray:
        # The law, written once: 1 − α(v) = (1 − α)(v / v₁)^p.
        ratio = np.asarray(ratio, float)
        exponent = _per_row(values[EXPONENT], alpha.shape, ratio)
        with np.errstate(all="ignore"):
            return 1.0 - _per_row(1.0 - alpha, alpha.shape, ratio) * ratio**exponent

    def propagation(self, alpha: NDArray, values: Values, ratios: NDArray) -> NDArray:
        before = np.ones_like(ratios)
        before[:, 1:] = ratios[:, :-1]  # r_{k−1}, the speed impact k comes in with
        restitution = self.restitution(alpha, values, before)  # α_k
        exponent = _per_row(values[EXPONENT], alpha.shape, ratios)
        return 1.0 - exponent * (1.0 - restitution) / restitution


def _column(value: ArrayLike, shape: tuple[int, ...]) -> NDArray:
    """A parameter as a float array of the batch's shape (a fixed one is a scalar)."""
    return np.broadcast_to(np.asarray(value, float), shape)


def _per_row(value: ArrayLike, shape: tuple[int, ...], like: NDArray) -> NDArray:
    """:func:`_column`, shaped to broadcast along the rows of ``like`` (one value per batch
    row, whether ``like`` holds one ratio per row or a row of them)."""
    return _column(value, shape).reshape(shape + (1,) * (like.ndim - len(shape)))


#: Every restitution law by name; the first is the default (a model's name without a slash).
LAWS: dict[str, RestitutionLaw] = {law.name: law for law in (Constant(), SpeedDependent())}
#: The law a model name without ``/LAW`` means.
DEFAULT_LAW: RestitutionLaw = next(iter(LAWS.values()))
