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

from drumroll.physics.bounces import BAD_RESTITUTION_LAW, Bounces
from drumroll.physics.geometry import StickGeometry
from drumroll.physics.restitution import DEFAULT_LAW, RestitutionLaw

#: Parameter values by internal name (SI): arrays of one batch shape, or scalars.
Values = Mapping[str, ArrayLike]
#: Step in u_k = ln r_k of :meth:`ForwardModel.restitution_slopes`' difference: truncation
#: error ~h/2 relative, round-off ~1e-16/h.
_SLOPE_STEP = 1e-6


class ForwardModel(ABC):
    """A forward model of a bouncer (see the module docstring): a motion between impacts (the
    subclass) under a restitution law (:mod:`drumroll.physics.restitution`).

    Class attributes (the motion's)
    -------------------------------
    motion
        The motion's name: the part of a model's name before the slash.
    motion_parameters
        Internal names (SI) of the motion's parameters, besides the stick's (``alpha`` is the
        first impact's restitution under any law).
    needs_stick
        Whether it needs a stick and the set-up's geometry (the pendulum models).
    motion_title
        Its name in words.
    colours
        How every figure draws it, by law (Okabe–Ito colours).
    linestyle
        Its line style (keeps coinciding curves apart); the speed law's is dash-dotted.

    Attributes (the model's)
    ------------------------
    law
        The restitution law.
    name
        The model's name in configs and outputs: ``MOTION`` for the constant law (eq. 9),
        ``MOTION/LAW`` otherwise (a contract).
    parameters
        The motion's parameters and the law's.
    title
        Its name in words (legends, verdicts: "the {title} is preferred").
    colour
        Its colour in every figure.
    """

    motion: ClassVar[str]
    motion_parameters: ClassVar[tuple[str, ...]]
    needs_stick: ClassVar[bool] = False
    motion_title: ClassVar[str]
    colours: ClassVar[dict[str, str]]
    linestyle: object = "-"

    def __init__(self, law: RestitutionLaw = DEFAULT_LAW) -> None:
        self.law = law
        constant = law is DEFAULT_LAW
        self.name = self.motion if constant else f"{self.motion}/{law.name}"
        self.parameters = (*self.motion_parameters, *law.parameters)
        self.title = self.motion_title if constant else f"{self.motion_title} with {law.title}"
        self.colour = self.colours[law.name]
        if not constant:
            self.linestyle = (0, (6, 1.5, 1, 1.5))

    #: Whether the flights are proportional to the rebound speeds, T_k = t_B r_k (then
    #: ∂T_k/∂u_k = T_k, no difference needed).
    geometric_flights: ClassVar[bool] = False

    @abstractmethod
    def flights_at(self, ratios: NDArray, values: Values, stick_shape: str | None = None,
                   g: float = 9.81) -> tuple[NDArray, NDArray]:
        """The kernel: flights T_1 … T_N whose rebound speeds are r_k times the first contact
        speed, and where the motion's parameters are valid.

        Parameters
        ----------
        ratios
            r_k, shape ``(batch, N)`` (:meth:`RestitutionLaw.speed_ratios`).
        values
            The parameters by internal name (:attr:`motion_parameters`, and ``stick_length``,
            ``stick_tip``, ``stick_radius`` for a model that needs a stick): arrays of shape
            ``(batch,)`` or scalars.
        stick_shape
            ``"thin-rod"`` or ``"cylinder-cone"`` (models that need a stick).
        g
            Gravitational acceleration (m/s²).

        Returns
        -------
        flights, valid
            Shapes ``(batch, N)`` and ``(batch,)``; rows that are not valid hold garbage.
        """

    def flights(self, values: Values, n_flights: int, stick_shape: str | None = None,
                g: float = 9.81) -> tuple[NDArray, NDArray]:
        """Flights T_1 … T_N of a batch of parameter points and where they are valid: the
        samplers' path (module docstring).

        Parameters
        ----------
        values
            The parameters by internal name (:attr:`parameters`, and the stick's for a model
            that needs one): arrays of shape ``(batch,)`` or scalars.
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
        return self._flights(values, n_flights, stick_shape, g)[2:]

    def _flights(self, values: Values, n_flights: int, stick_shape: str | None, g: float
                 ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """α, the law's speed ratios, the flights and where all are valid (:meth:`flights`)."""
        alpha = alpha_of(values)
        ratios, law_valid = self.law.speed_ratios(alpha, values, n_flights)
        flights, valid = self.flights_at(ratios, values, stick_shape, g)
        return alpha, ratios, flights, valid & law_valid

    @abstractmethod
    def bounces_at(self, values: dict[str, NDArray], ratios: NDArray, n_flights: int,
                   stick: StickGeometry | None = None, g: float = 9.81) -> Bounces:
        """:meth:`bounces` for parameters already broadcast to one 1-d shape and the law's
        ratios (computed with a safe α where α is not valid)."""

    def bounces(self, values: Values, n_flights: int, stick: StickGeometry | None = None,
                g: float = 9.81) -> Bounces:
        """The same flights with the fall and contact state, every invalid point masked
        with its reason (the parameters broadcast together): the public path."""
        names = tuple(values)
        arrays = dict(zip(names, batch(*(values[name] for name in names)), strict=True))
        alpha = arrays["alpha"]
        fine = np.isfinite(alpha) & alpha_valid(alpha)
        ratios, law_valid = self.law.speed_ratios(np.where(fine, alpha, 0.5), arrays,
                                                  n_flights)
        bounces = self.bounces_at(arrays, ratios, n_flights, stick, g)
        return bounces.invalidated(~law_valid, BAD_RESTITUTION_LAW)

    def height_ratio(self, theta_c: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """h / (L − d) at the contact angle θ_C, its derivative with respect to θ_C, and where
        θ_C is a possible contact (models that need a stick: the geometry the model assumes,
        exact or linearised)."""
        raise NotImplementedError(f"the {self.name} model has no stick")

    def contact_angle(self, ratio: NDArray) -> NDArray:
        """θ_C from h / (L − d): the inverse of :meth:`height_ratio`."""
        raise NotImplementedError(f"the {self.name} model has no stick")

    def restitution_slopes(self, values: Values, n_flights: int, stick_shape: str | None = None,
                           g: float = 9.81
                           ) -> tuple[NDArray, NDArray, NDArray | None, NDArray]:
        """Flights T_k, their slopes ∂T_k/∂u_k, the law's propagation, and where they are
        valid.

        Flight k depends on the restitutions only through u_k = ln r_k = Σ_{j≤k} ln α_j
        (:mod:`drumroll.physics.restitution`). A change ε_j of one bounce's ln α_j moves u_k
        for k ≥ j by D_kj ε_j, D_kj = Π_{j<i≤k} ∂u_i/∂u_{i−1} (1 for a constant α, eq. 9), and
        flight k by ``slope_k · D_kj · ε_j`` to first order: this is what a scatter of the
        restitution from bounce to bounce does to the flights
        (:mod:`drumroll.inference.scatter`).

        Geometric motions (T_k = t_B r_k) have slope_k = T_k exactly; the others take a
        backward difference in u_k (r_k e^{−h} keeps every speed possible), relative error
        ~h.

        Returns
        -------
        flights, slopes, propagation, valid
            Shapes ``(batch, N)``, ``(batch, N)``, ``(batch, N)`` or None (the law's
            ∂u_k/∂u_{k−1}, :meth:`RestitutionLaw.propagation`; None where it is 1) and
            ``(batch,)``.
        """
        alpha, ratios, flights, valid = self._flights(values, n_flights, stick_shape, g)
        propagation = self.law.propagation(alpha, values, ratios)
        if self.geometric_flights:
            return flights, flights, propagation, valid
        below, _ = self.flights_at(ratios * math.exp(-_SLOPE_STEP), values, stick_shape, g)
        return flights, (flights - below) / _SLOPE_STEP, propagation, valid

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


def geometric(t_b: NDArray, ratios: NDArray) -> NDArray:
    """T_k = t_B r_k, k = 1 … N, per row (eq. 11 when r_k = α^k): the power law's and the
    small-angle pendulum's flights."""
    return t_b[:, None] * ratios


def alpha_valid(alpha: NDArray) -> NDArray:
    """Where α is a coefficient of restitution: 0 < α ≤ 1 (eq. 9)."""
    return (alpha > 0.0) & (alpha <= 1.0)
