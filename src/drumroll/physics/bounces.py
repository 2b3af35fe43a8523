"""The result every forward model returns: a batch of bounce sequences."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

#: Why a parameter point cannot make a drumroll; index = code stored in ``Bounces.reason``.
REASONS: tuple[str, ...] = (
    "",
    "the pivot is at or beyond the centre of mass, so the stick does not fall (d >= l_C)",
    "the tip cannot reach the drumhead from this height and pivot (h >= L - d)",
    "the height must be positive",
    "the stick is released at or below the contact angle",
    "the release angle must lie between -90 and 90 degrees",
    "the release speed must be zero or positive (tip moving down)",
    "the restitution coefficient must lie in (0, 1]",
    "a rebound goes over the top and never comes back (restitution or release speed too high)",
    "the flight time must be positive",
    "the pivot must lie on the stick (d >= 0)",
    "every parameter must be a finite number",
    "the rim of the cone strikes the drumhead before its tip (the contact angle is below "
    "atan(R / l2)), which no model here describes",
    "the restitution law leaves (0, 1] or makes a harder impact rebound slower",
)
OK, PIVOT_PAST_CM, TIP_CANNOT_REACH, HEIGHT_NOT_POSITIVE, RELEASED_BELOW_CONTACT, \
    BAD_RELEASE_ANGLE, NEGATIVE_RELEASE_SPEED, BAD_ALPHA, OVER_THE_TOP, BAD_T_B, \
    PIVOT_OFF_STICK, NOT_FINITE, RIM_FIRST, BAD_RESTITUTION_LAW = range(len(REASONS))


def first_failure(checks: list[tuple[int, NDArray[np.bool_]]], shape: tuple[int, ...]
                  ) -> NDArray[np.int8]:
    """Reason code per batch element: the first failing check's code, 0 where all pass."""
    reason = np.zeros(shape, dtype=np.int8)
    for code, failed in reversed(checks):  # reversed so the first failing check wins
        reason = np.where(failed, np.int8(code), reason)
    return reason


@dataclass(frozen=True)
class Bounces:
    """A batch of bounce sequences (leading axis: parameter sets).

    Impacts are numbered k = 0 (the first impact) … N; flight k lies between impacts k−1 and
    k and starts with upward angular speed r_k ω_C, r_k = α^k under a constant restitution
    (physics.md; :mod:`drumroll.physics.restitution`). Entries of an invalid
    parameter point are NaN; ``reason`` says why it is invalid.

    Attributes
    ----------
    alpha
        Coefficient of restitution α, shape ``(batch,)``.
    flights
        Flight times T_1 … T_N (s), shape ``(batch, N)``.
    speed_ratios
        r_1 … r_N: the rebound speed after k impacts over the first contact speed (α^k for a
        constant restitution), shape ``(batch, N)``.
    t_c
        Fall time from release to the first impact (s); NaN for the power law, which has no
        geometry.
    t_b
        First-rebound time: the flight at the full contact speed (s), the N = 0 term of eq. 11;
        ``inf`` where such a flight would go over the top.
    theta_c
        Contact angle θ_C (rad).
    omega_c
        Angular speed at the first impact ω_C (rad/s).
    tip_speed_c
        Speed of the tip at the first impact, ω_C (L − d) (m/s).
    reason
        0 where the parameter point is valid, else an index into :data:`REASONS`.
    """

    alpha: NDArray
    flights: NDArray
    speed_ratios: NDArray
    t_c: NDArray
    t_b: NDArray
    theta_c: NDArray
    omega_c: NDArray
    tip_speed_c: NDArray
    reason: NDArray[np.int8]

    @property
    def valid(self) -> NDArray[np.bool_]:
        """True where the parameter point makes a drumroll."""
        return self.reason == OK

    @property
    def n_flights(self) -> int:
        """Number of flights N in each sequence."""
        return self.flights.shape[-1]

    @property
    def impacts(self) -> NDArray:
        """Impact times τ_0 = 0, τ_k = Σ_{j≤k} T_j (s), shape ``(batch, N + 1)``."""
        zeros = np.zeros((*self.flights.shape[:-1], 1))
        return np.concatenate([zeros, np.cumsum(self.flights, axis=-1)], axis=-1)

    @property
    def impact_tip_speeds(self) -> NDArray:
        """Tip speed arriving at impact k, r_k × ``tip_speed_c`` (m/s), shape ``(batch, N+1)``.

        Between impacts energy is conserved, so flight k lands as fast as it left.
        """
        ones = np.ones((*self.speed_ratios.shape[:-1], 1))
        return self.tip_speed_c[..., None] * np.concatenate([ones, self.speed_ratios], axis=-1)

    def invalidated(self, where: NDArray[np.bool_], code: int) -> Bounces:
        """These bounces with the valid points ``where`` is True made invalid for reason
        ``code`` (their fields NaN)."""
        bad = where & self.valid
        if not np.any(bad):
            return self
        reason = np.where(bad, np.int8(code), self.reason)
        return masked_bounces(reason, **{f.name: getattr(self, f.name) for f in fields(self)
                                         if f.name != "reason"})

    def reasons(self) -> list[str]:
        """The reason text of each batch element ('' where valid)."""
        return [REASONS[int(code)] for code in np.ravel(self.reason)]


def masked_bounces(reason: NDArray[np.int8], **fields: NDArray) -> Bounces:
    """Build :class:`Bounces`, with NaN in every field of an invalid element.

    ``alpha`` is kept as given so that a caller can still see which α was asked for; the
    models compute with :func:`safe_alpha` instead.
    """
    bad = reason != OK
    masked = {name: (value if name == "alpha" else
                     np.where(bad[:, None] if value.ndim == 2 else bad, np.nan, value))
              for name, value in fields.items()}
    return Bounces(reason=reason, **masked)


def safe_alpha(alpha: NDArray, reason: NDArray[np.int8]) -> NDArray:
    """α where the point is valid, a harmless 0.5 elsewhere (no overflow in α^k)."""
    return np.where(reason == OK, alpha, 0.5)
