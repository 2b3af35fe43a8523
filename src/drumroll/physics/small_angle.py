"""The small-angle pendulum (eqs. 6–7, 10–11): constant angular acceleration γ.

Linearising sin θ ≈ θ and cos θ ≈ 1 makes every flight a parabola in θ(t), so the flights are
exactly geometric, T_k = 2 α^k ω_C / γ, and h, d and the release speed enter only through
ω_C / γ (physics.md).
"""

from __future__ import annotations

import numpy as np

from drumroll.physics.bounces import (
    RELEASED_BELOW_CONTACT,
    Bounces,
    masked_bounces,
    safe_alpha,
)
from drumroll.physics.release import Release


def small_angle_bounces(release: Release, n_flights: int) -> Bounces:
    """Bounce sequences of the linearised pendulum.

    Parameters
    ----------
    release
        The prepared set-up (:func:`~drumroll.physics.release.prepare_release`).
    n_flights
        Number N of flights to return.

    Returns
    -------
    Bounces
        With θ_C ≈ h / (L − d), ω_C = sqrt(ω0² + 2γ(θ_C − θ0)), t_C = (ω_C − ω0)/γ
        (eq. 7 when ω0 = θ0 = 0) and T_k = 2 α^k ω_C / γ (eq. 11 with t_B = 2 ω_C / γ).
    """
    r = release
    theta_c = r.sin_theta_c  # linearised contact angle h / (L − d)
    reason = np.where((r.reason == 0) & ~(r.theta0 < theta_c),
                      np.int8(RELEASED_BELOW_CONTACT), r.reason)
    omega_c = np.sqrt(r.omega0**2 + 2.0 * r.gamma * np.maximum(theta_c - r.theta0, 0.0))
    t_b = 2.0 * omega_c / r.gamma
    k = np.arange(1, n_flights + 1)
    flights = t_b[:, None] * safe_alpha(r.alpha, reason)[:, None] ** k
    return masked_bounces(reason, alpha=r.alpha, flights=flights,
                          t_c=(omega_c - r.omega0) / r.gamma, t_b=t_b, theta_c=theta_c,
                          omega_c=omega_c, tip_speed_c=omega_c * r.arm)
