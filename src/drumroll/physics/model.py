"""What a forward model is: a name, its parameters, and two front ends on one kernel.

Each model lives in its own module as a subclass of :class:`ForwardModel` and is registered
in :data:`drumroll.physics.models.MODELS` (as emcee keeps one move per file behind a small
base class). A model's flights are computed by one kernel, which both front ends call:

* :meth:`ForwardModel.flights` is the samplers' path: a batch of parameter points (arrays of
  one shape, or scalars for fixed parameters) to the flights and one validity mask, with no
  broadcasting, masking or reason bookkeeping;
* :meth:`ForwardModel.bounces` is the public path (:func:`~drumroll.physics.bounce_sequence`):
  the same flights inside a :class:`~drumroll.physics.bounces.Bounces` with the fall time,
  the contact state and the reason every invalid point fails.

Adding a model is one module with one subclass, one line in the registry, and its tests.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drumroll.physics.bounces import Bounces
from drumroll.physics.geometry import StickGeometry

#: Parameter values by internal name (SI): arrays of one batch shape, or scalars.
Values = Mapping[str, ArrayLike]
#: Step in ln α of :meth:`ForwardModel.restitution_slopes`' difference: truncation error
#: ~k·h/2 relative (5e-5 at k = 100), round-off ~1e-16/h.
_SLOPE_STEP = 1e-6


class ForwardModel(ABC):
    """A forward model of a bouncer (see the module docstring).

    Attributes
    ----------
    name
        The model's name in configs and outputs.
    parameters
        Internal names (SI) of the parameters its kernel takes, besides the stick's.
    needs_stick
        Whether it needs a stick and the set-up's geometry (the pendulum models).
    title
        Its name in words (legends, verdicts: "the {title} is preferred").
    colour, linestyle
        How every figure draws it (Okabe–Ito colours; line styles that keep coinciding
        curves apart).
    """

    name: ClassVar[str]
    parameters: ClassVar[tuple[str, ...]]
    needs_stick: ClassVar[bool] = False
    title: ClassVar[str]
    colour: ClassVar[str]
    linestyle: ClassVar[object] = "-"

    @abstractmethod
    def flights(self, values: Values, n_flights: int, stick_shape: str | None = None,
                g: float = 9.81) -> tuple[NDArray, NDArray]:
        """Flights T_1 … T_N of a batch of parameter points and where they are valid.

        Parameters
        ----------
        values
            The parameters by internal name (:attr:`parameters`, and ``stick_length``,
            ``stick_tip``, ``stick_radius`` for a model that needs a stick): arrays of shape
            ``(batch,)`` or scalars.
        n_flights
            N.
        stick_shape
            ``"thin-rod"`` or ``"cylinder-cone"`` (models that need a stick).
        g
            Gravitational acceleration (m/s²).

        Returns
        -------
        flights, valid
            Shapes ``(batch, N)`` and ``(batch,)``; rows that are not valid hold garbage.
        """

    @abstractmethod
    def bounces(self, values: Values, n_flights: int, stick: StickGeometry | None = None,
                g: float = 9.81) -> Bounces:
        """The same flights with the fall and contact state, every invalid point masked
        with its reason (the parameters broadcast together)."""

    def height_ratio(self, theta_c: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """h / (L − d) at the contact angle θ_C, its derivative with respect to θ_C, and where
        θ_C is a possible contact (models that need a stick: the geometry the model assumes,
        exact or linearised)."""
        raise NotImplementedError(f"the {self.name} model has no stick")

    def contact_angle(self, ratio: NDArray) -> NDArray:
        """θ_C from h / (L − d): the inverse of :meth:`height_ratio`."""
        raise NotImplementedError(f"the {self.name} model has no stick")

    #: Whether the flights are T_k = t_B α^k exactly (then ∂T_k/∂u_k = T_k, no difference).
    geometric_flights: ClassVar[bool] = False

    def restitution_slopes(self, values: Values, n_flights: int, stick_shape: str | None = None,
                           g: float = 9.81) -> tuple[NDArray, NDArray, NDArray]:
        """Flights T_k, their slopes ∂T_k/∂u_k, and where they are valid.

        Every model here loses speed only at the impacts (energy is conserved in flight), so
        the rebound speed after k impacts is the contact speed times α_1 ⋯ α_k, and flight k
        depends on the restitutions only through u_k = Σ_{j≤k} ln α_j (= k ln α for a constant
        α, eq. 9). A change ε_j of one bounce's ln α_j therefore moves flight k ≥ j by
        ``slope_k · ε_j`` to first order: this is what a scatter of the restitution from
        bounce to bounce does to the flights (:mod:`drumroll.inference.scatter`).

        Geometric models (T_k = t_B e^{u_k}) have slope_k = T_k exactly; the others take a
        backward difference in ln α (α e^{−h} keeps α ≤ 1), relative error ~k·h.

        Returns
        -------
        flights, slopes, valid
            Shapes ``(batch, N)``, ``(batch, N)`` and ``(batch,)``.
        """
        flights, valid = self.flights(values, n_flights, stick_shape, g)
        if self.geometric_flights:
            return flights, flights, valid
        lower = dict(values)
        lower["alpha"] = np.asarray(values["alpha"], float) * math.exp(-_SLOPE_STEP)
        below, _ = self.flights(lower, n_flights, stick_shape, g)
        k = np.arange(1.0, n_flights + 1.0)
        return flights, (flights - below) / (k * _SLOPE_STEP), valid

    def impacts(self, values: Values, n_flights: int, stick_shape: str | None = None,
                g: float = 9.81) -> tuple[NDArray, NDArray]:
        """Impact times τ_0 = 0, τ_k = Σ_{j≤k} T_j, shape ``(batch, N + 1)``, and validity."""
        flights, valid = self.flights(values, n_flights, stick_shape, g)
        impacts = np.zeros((flights.shape[0], n_flights + 1))
        np.cumsum(flights, axis=1, out=impacts[:, 1:])
        return impacts, valid


def batch(*values: ArrayLike) -> tuple[NDArray, ...]:
    """The values as float arrays of one 1-d batch shape."""
    return tuple(np.atleast_1d(v) for v in np.broadcast_arrays(
        *(np.asarray(v, float) for v in values)))


def alpha_of(values: Values) -> NDArray:
    """α as a 1-d array of the batch's shape (the samplers pass it as a column already;
    where it is fixed, the batch's shape is that of the other values)."""
    alpha = values["alpha"]
    if isinstance(alpha, np.ndarray) and alpha.ndim == 1:
        return alpha
    shape = np.broadcast(*(np.asarray(v) for v in values.values())).shape or (1,)
    return np.broadcast_to(np.asarray(alpha, float), shape)


def geometric(t_b: NDArray, alpha: NDArray, n_flights: int) -> NDArray:
    """T_k = t_B α^k, k = 1 … N, per row (eq. 11): the power law's and the small-angle
    pendulum's flights."""
    return t_b[:, None] * alpha[:, None] ** np.arange(1.0, n_flights + 1.0)


def alpha_valid(alpha: NDArray) -> NDArray:
    """Where α is a coefficient of restitution: 0 < α ≤ 1 (eq. 9)."""
    return (alpha > 0.0) & (alpha <= 1.0)
