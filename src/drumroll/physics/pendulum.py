"""The exact pendulum: θ̈ = γ cos θ between impacts, solved in closed form.

With ψ = π/2 − θ (the angle from the hanging vertical) the motion is a plain pendulum,
ψ̈ = −γ sin ψ, whose energy m = sin²(ψ/2) + ψ̇²/(4γ) is conserved between impacts. Every time
of travel is then an incomplete elliptic integral of the first kind, F(φ | m) =
``scipy.special.ellipkinc`` (parameter m = k²). This is the paper's eq. 5, generalised to a
release angle and speed, and exact: no ODE is integrated.

Numerically, every flight and the fall from rest are written as a single F(χ | m) through the
complementary amplitude, K(m) − F(φ | m) = F(χ | m) with sin²χ = (m − s) / (m (1 − s)) and
s = sin²(ψ/2). This costs one special-function call per flight and stays accurate for the
slow, late flights, where K − F would cancel.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.special import ellipkinc

from drumroll.physics.bounces import (
    OK,
    OVER_THE_TOP,
    RELEASED_BELOW_CONTACT,
    Bounces,
    masked_bounces,
)
from drumroll.physics.release import Release


def _from_turning_point(excess: NDArray, m: NDArray, s: NDArray) -> NDArray:
    """F(χ | m): the elliptic phase from the angle with ``s`` to the turning point.

    Parameters
    ----------
    excess
        m − s = ψ̇² / (4γ) at that angle (≥ 0).
    m
        Energy parameter, m < 1 (the swing turns back below the top).
    s
        sin²(ψ/2) = (1 − sin θ) / 2 at that angle.

    Returns
    -------
    NDArray
        F(χ | m) = K(m) − F(φ | m); divide by √γ for the time to the turning point.
    """
    sin2_chi = np.clip(excess / (m * (1.0 - s)), 0.0, 1.0)
    return ellipkinc(np.arcsin(np.sqrt(sin2_chi)), m)


def pendulum_bounces(release: Release, n_flights: int) -> Bounces:
    """Bounce sequences of the exact pendulum (closed form; physics.md).

    Parameters
    ----------
    release
        The prepared set-up (:func:`~drumroll.physics.release.prepare_release`).
    n_flights
        Number N of flights to return.

    Returns
    -------
    Bounces
        t_C from the release (θ0, ω0) to θ_C, including a fall with m0 > 1 (enough energy to
        pass over the top); ω_C from energy conservation (eq. 4 when θ0 = ω0 = 0); flights
        T_k = 2 F(χ_k | m_k) / √γ with m_k = s_C + α^{2k} (m0 − s_C). A point where a flight
        would have m_k ≥ 1 (over the top, never to return) is invalid; t_B is ``inf`` when
        only the fully elastic first rebound would pass over the top.
    """
    r = release
    theta_c = np.arcsin(r.sin_theta_c)
    reason = np.where((r.reason == OK) & ~(r.theta0 < theta_c),
                      np.int8(RELEASED_BELOW_CONTACT), r.reason)
    root_gamma = np.sqrt(r.gamma)
    s_c = 0.5 * (1.0 - r.sin_theta_c)
    s_0 = 0.5 * (1.0 - np.sin(r.theta0))
    m_0 = s_0 + r.omega0**2 / (4.0 * r.gamma)
    contact_excess = np.maximum(m_0 - s_c, 0.0)  # ω_C² / (4γ)

    # Fall. Below the top (m0 < 1) both ends are measured from the turning point; above it the
    # modulus is inverted and the amplitude is ψ/2 itself.
    libration = m_0 < 1.0
    m_lib = np.where(libration, m_0, 0.5)
    fall_libration = (_from_turning_point(contact_excess, m_lib, s_c)
                      - _from_turning_point(m_0 - s_0, m_lib, s_0)) / root_gamma
    m_inv = np.where(libration, 0.5, 1.0 / np.maximum(m_0, 1.0))
    half_psi_0 = 0.25 * np.pi - 0.5 * r.theta0
    half_psi_c = 0.25 * np.pi - 0.5 * theta_c
    fall_rotation = ((ellipkinc(half_psi_0, m_inv) - ellipkinc(half_psi_c, m_inv))
                     / (root_gamma * np.sqrt(np.maximum(m_0, 1.0))))
    t_c = np.where(libration, fall_libration, fall_rotation)
    omega_c = 2.0 * root_gamma * np.sqrt(contact_excess)

    # Flights k = 0 … N; k = 0 (full contact speed) is t_B, the N = 0 term of eq. 11.
    k = np.arange(n_flights + 1)
    excess = contact_excess[:, None] * r.alpha[:, None] ** (2 * k)
    m_k = s_c[:, None] + excess
    returns = m_k < 1.0
    phase = _from_turning_point(excess, np.where(returns, m_k, 0.5), s_c[:, None])
    all_flights = np.where(returns, 2.0 * phase / root_gamma[:, None], np.inf)
    reason = np.where((reason == OK) & ~returns[:, 1:].all(axis=1), np.int8(OVER_THE_TOP),
                      reason)
    return masked_bounces(reason, alpha=r.alpha, flights=all_flights[:, 1:], t_c=t_c,
                          t_b=all_flights[:, 0], theta_c=theta_c, omega_c=omega_c,
                          tip_speed_c=omega_c * r.arm)
