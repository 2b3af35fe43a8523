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
    RIM_FIRST,
    TIP_CANNOT_REACH,
    Bounces,
    first_failure,
)
from drumroll.physics.geometry import (
    STICK_SHAPES,
    StickGeometry,
    mass_properties_squared,
    overall_length,
)

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


def swing(shape: str, length: ArrayLike, tip: ArrayLike, radius: ArrayLike, pivot: ArrayLike,
          height: ArrayLike, release_speed: ArrayLike, release_angle: ArrayLike,
          g: float = STANDARD_GRAVITY) -> tuple[tuple[tuple[int, NDArray], ...], tuple]:
    """The set-up's checks, and γ, the arm and sin θ_C: the one place they are computed.

    Every pendulum path starts here: :func:`prepare_release` (the public forward models, with
    a reason per failure) and the sampler's kernels (one validity mask). Nothing is
    broadcast or masked: the arguments are arrays of one batch shape or scalars, and where a
    check fails the other values are garbage.

    Parameters
    ----------
    shape, length, tip, radius
        The stick (:func:`~drumroll.physics.geometry.mass_properties_squared`).
    pivot, height, release_speed, release_angle
        d, h (m), the release tip speed (m/s) and angle (rad).
    g
        Gravitational acceleration (m/s²).

    Returns
    -------
    checks, (gamma, arm, sin_theta_c, omega0)
        ``checks`` pairs each reason code of :data:`~drumroll.physics.bounces.REASONS` with
        where the set-up passes it (the first failed one is the reason). γ = g (l_C − d) / K_O²
        (eq. 6), the arm L − d, sin θ_C = h / (L − d) and ω0 = release speed / arm.
    """
    with np.errstate(all="ignore"):  # invalid points are flagged by the checks
        pivot, height, release_speed, release_angle = (
            np.asarray(v, float) for v in (pivot, height, release_speed, release_angle))
        total_length, centre_of_mass, k_o_squared = mass_properties_squared(
            shape, length, tip, radius, pivot)
        arm = total_length - pivot
        checks = (
            (NOT_FINITE, np.isfinite(pivot + height + release_speed + release_angle
                                     + total_length + centre_of_mass + k_o_squared)),
            (PIVOT_OFF_STICK, pivot >= 0),
            (PIVOT_PAST_CM, pivot < centre_of_mass),
            (HEIGHT_NOT_POSITIVE, height > 0),
            (TIP_CANNOT_REACH, height < arm),
            (BAD_RELEASE_ANGLE, np.abs(release_angle) < 0.5 * np.pi),
            (NEGATIVE_RELEASE_SPEED, release_speed >= 0),
        )
        gamma = g * (centre_of_mass - pivot) / k_o_squared
        return checks, (gamma, arm, height / arm, release_speed / arm)


def tip_strikes_first(shape: str, tip: ArrayLike, radius: ArrayLike, height: ArrayLike,
                      arm: ArrayLike) -> NDArray:
    """Whether the tip, not the rim of its cone, meets the drumhead first.

    A cone of length l2 and base radius R has half-angle β = atan(R / l2); with the stick at
    θ_C to the head its lowest generator rises towards the tip when θ_C < β, so the rim
    strikes first (h < 34 mm at d = 131 mm for the paper's stick). Every model here assumes the
    tip strikes: sin θ_C = h / (L − d) ≥ sin β = R / √(R² + l2²). A thin rod has no cone.

    The forward models themselves are mathematics and compute any height (the tests compare
    them with ODE integration down to 4 mm); what a user runs (the config's nominal set-up,
    ``predict``'s draws, ``estimate``'s posterior) is held to this check.
    """
    if shape == "thin-rod":
        return np.ones(np.shape(height), bool)
    return height * np.hypot(radius, tip) >= radius * arm


def rim_strikes_first(shape: str, length: ArrayLike, tip: ArrayLike, radius: ArrayLike,
                      pivot: ArrayLike, height: ArrayLike) -> NDArray:
    """Where the rim of the cone, not the tip, would strike first (:func:`tip_strikes_first`)
    for a stick pivoted at ``pivot`` at ``height``: False wherever the set-up is otherwise
    impossible (its own reason applies there)."""
    with np.errstate(all="ignore"):
        arm = overall_length(shape, length, tip) - np.asarray(pivot, float)
        reachable = (np.asarray(height, float) > 0) & (np.asarray(height, float) < arm)
        return reachable & ~tip_strikes_first(shape, tip, radius, height, arm)


def tip_contact_only(bounces: Bounces, stick: StickGeometry, pivot: ArrayLike,
                     height: ArrayLike) -> Bounces:
    """``bounces`` with every point where the rim would strike first made invalid (reason
    :data:`~drumroll.physics.bounces.RIM_FIRST`, fields NaN): what a user's run is held to."""
    return bounces.invalidated(rim_strikes_first(stick.shape, stick.length, stick.tip,
                                                 stick.radius, pivot, height), RIM_FIRST)


def passes(checks: tuple[tuple[int, NDArray], ...], valid: NDArray) -> NDArray:
    """``valid`` where every one of :func:`swing`'s checks passes as well."""
    for _, ok in checks:
        valid = valid & ok
    return valid


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
    alpha, pivot, height, release_speed, release_angle, length, tip, radius = (
        np.atleast_1d(x) for x in np.broadcast_arrays(
            *(np.asarray(v, float) for v in (alpha, pivot, height, release_speed,
                                             release_angle, stick.length, stick.tip,
                                             stick.radius))))
    if stick.shape not in STICK_SHAPES:
        raise ValueError(f"unknown stick shape {stick.shape!r}; expected one of {STICK_SHAPES}")
    checks, (gamma, arm, sin_theta_c, omega0) = swing(
        stick.shape, length, tip, radius, pivot, height, release_speed, release_angle, g)
    (code, finite), *rest = checks
    reason = first_failure([(code, ~(finite & np.isfinite(alpha))),
                            (BAD_ALPHA, ~((alpha > 0) & (alpha <= 1))),
                            *((code, ~ok) for code, ok in rest)], alpha.shape)
    bad = reason != 0
    # Placeholders keep invalid elements finite, so vectorised maths needs no masking.
    return Release(alpha=alpha, gamma=np.where(bad, 1.0, gamma), arm=np.where(bad, 1.0, arm),
                   sin_theta_c=np.where(bad, 0.5, sin_theta_c),
                   theta0=np.where(bad, 0.0, release_angle),
                   omega0=np.where(bad, 0.0, omega0), reason=reason)
