"""From the set-up (stick, pivot, height, release) to the quantities the pendulum models use."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drumroll.physics.bounces import (
    BAD_ALPHA,
    BAD_RELEASE_ANGLE,
    HEIGHT_NOT_POSITIVE,
    NEGATIVE_RELEASE_SPEED,
    NOT_FINITE,
    PIVOT_OFF_STICK,
    PIVOT_PAST_CM,
    TIP_CANNOT_REACH,
    first_failure,
)
from drumroll.physics.geometry import StickGeometry

#: Standard gravity (m/s²), used unless the config gives another value.
STANDARD_GRAVITY = 9.81


@dataclass(frozen=True)
class Release:
    """A batch of drops, reduced to what the equation of motion needs (SI units).

    Attributes
    ----------
    alpha
        Coefficient of restitution α, as given (models use
        :func:`~drumroll.physics.bounces.safe_alpha` for arithmetic).
    gamma
        Angular acceleration scale γ = g (l_C − d) / K_O² (rad/s², eq. 6).
    arm
        Distance from the pivot to the tip, L − d (m).
    sin_theta_c
        sin θ_C = h / (L − d), the exact contact condition.
    theta0, omega0
        Release angle (rad, 0 = horizontal) and angular speed (rad/s, tip down > 0).
    reason
        Failure code per element (0 = valid so far); see :data:`~drumroll.physics.bounces.REASONS`.
    """

    alpha: NDArray
    gamma: NDArray
    arm: NDArray
    sin_theta_c: NDArray
    theta0: NDArray
    omega0: NDArray
    reason: NDArray[np.int8]


def prepare_release(
    alpha: ArrayLike,
    pivot: ArrayLike,
    height: ArrayLike,
    stick: StickGeometry,
    release_speed: ArrayLike = 0.0,
    release_angle: ArrayLike = 0.0,
    g: float = STANDARD_GRAVITY,
) -> Release:
    """Reduce the physical set-up to γ, θ_C, θ0 and ω0, checking that it can bounce.

    Parameters
    ----------
    alpha
        Coefficient of restitution α (eq. 9).
    pivot
        Pivot distance d from the butt (m).
    height
        Height h of the pivot above the drumhead (m).
    stick
        Shape and dimensions of the stick.
    release_speed
        Tip speed at release, ω0 (L − d) (m/s, tip moving down).
    release_angle
        Release angle θ0 below the horizontal (rad).
    g
        Gravitational acceleration (m/s²).

    Returns
    -------
    Release
        All fields broadcast to one 1-d batch shape; invalid elements carry a reason code and
        harmless finite placeholder values, so later arithmetic never warns.
    """
    alpha, pivot, height, release_speed, release_angle = (
        np.atleast_1d(x) for x in np.broadcast_arrays(
            *(np.asarray(v, float) for v in (alpha, pivot, height, release_speed,
                                             release_angle))))
    total_length, centre_of_mass, radius_of_gyration = stick.mass_properties(pivot)
    total_length, centre_of_mass, radius_of_gyration = np.broadcast_arrays(
        total_length, centre_of_mass, radius_of_gyration, alpha)[:3]
    arm = total_length - pivot
    reason = first_failure(
        [
            (NOT_FINITE, ~np.isfinite(alpha + pivot + height + release_speed + release_angle
                                      + total_length + centre_of_mass + radius_of_gyration)),
            (BAD_ALPHA, ~((alpha > 0) & (alpha <= 1))),
            (PIVOT_OFF_STICK, ~(pivot >= 0)),
            (PIVOT_PAST_CM, ~(pivot < centre_of_mass)),
            (HEIGHT_NOT_POSITIVE, ~(height > 0)),
            (TIP_CANNOT_REACH, ~(height < arm)),
            (BAD_RELEASE_ANGLE, ~(np.abs(release_angle) < 0.5 * np.pi)),
            (NEGATIVE_RELEASE_SPEED, ~(release_speed >= 0)),
        ],
        alpha.shape,
    )
    bad = reason != 0
    # Placeholders keep invalid elements finite, so vectorised maths needs no masking.
    gamma = np.where(bad, 1.0, g * (centre_of_mass - pivot) / radius_of_gyration**2)
    arm = np.where(bad, 1.0, arm)
    sin_theta_c = np.where(bad, 0.5, height / arm)
    theta0 = np.where(bad, 0.0, release_angle)
    omega0 = np.where(bad, 0.0, release_speed / arm)
    return Release(alpha=alpha, gamma=gamma, arm=arm,
                   sin_theta_c=sin_theta_c, theta0=theta0, omega0=omega0, reason=reason)
