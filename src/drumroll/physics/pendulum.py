"""The exact pendulum: θ̈ = γ cos θ between impacts, solved in closed form.

With ψ = π/2 − θ (the angle from the hanging vertical) the motion is a plain pendulum,
ψ̈ = −γ sin ψ, whose energy m = sin²(ψ/2) + ψ̇²/(4γ) is conserved between impacts. Every time
of travel is then an incomplete elliptic integral of the first kind, F(φ | m) =
``scipy.special.ellipkinc`` (parameter m = k²). This is the paper's eq. 5, generalised to a
release angle and speed, and exact: no ODE is integrated.

Numerically, every time is measured from the turning point through the complementary
amplitude, K(m) − F(φ | m) = F(χ | m) with sin²χ = e / (m (1 − s)), where s = sin²(ψ/2) and
e = m − s = ψ̇²/(4γ) is the kinetic "excess" at that angle. The excesses, s, 1 − s and 1 − m are
carried separately (s − s' = sin(ψ/2 − ψ'/2) sin(ψ/2 + ψ'/2)), never recovered by subtracting
nearly equal numbers, so a tiny release speed, a release close to upright and the slow, late
flights all keep full precision. The fall uses Carlson's symmetric form,
F(χ | m) = √e R_F(s(1 − m), m(1 − m), m(1 − s)), which stays accurate as m → 1; each flight is
one ``ellipkinc`` call.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.special import ellipkinc, elliprf

from drumroll.physics.bounces import (
    OK,
    OVER_THE_TOP,
    RELEASED_BELOW_CONTACT,
    Bounces,
    masked_bounces,
    safe_alpha,
)
from drumroll.physics.release import Release


def _phase_from_turning_point(excess: NDArray, s: NDArray, one_minus_s: NDArray, m: NDArray,
                              one_minus_m: NDArray) -> NDArray:
    """F(χ | m) = K(m) − F(φ | m) in Carlson's form (m < 1); divide by √γ for a time.

    Parameters
    ----------
    excess
        e = m − s = ψ̇² / (4γ) at the angle (≥ 0).
    s, one_minus_s
        sin²(ψ/2) and cos²(ψ/2) at the angle.
    m, one_minus_m
        The energy parameter and its complement (> 0).
    """
    return np.sqrt(excess) * elliprf(s * one_minus_m, m * one_minus_m, m * one_minus_s)


def _phase_over_the_top(half_psi: NDArray, excess: NDArray, one_minus_s: NDArray, m: NDArray
                        ) -> NDArray:
    """F(ψ/2 | 1/m) for a swing with m ≥ 1 (no turning point), in Carlson's form.

    1 − sin²(ψ/2)/m = e/m, so the second argument needs no subtraction.
    """
    return np.sin(half_psi) * elliprf(one_minus_s, excess / m, 1.0)


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
    half_psi_0 = 0.25 * np.pi - 0.5 * r.theta0
    half_psi_c = 0.25 * np.pi - 0.5 * theta_c
    s_0, c_0 = np.sin(half_psi_0) ** 2, np.cos(half_psi_0) ** 2
    s_c, c_c = np.sin(half_psi_c) ** 2, np.cos(half_psi_c) ** 2
    release_excess = r.omega0**2 / (4.0 * r.gamma)
    drop = np.sin(half_psi_0 - half_psi_c) * np.sin(half_psi_0 + half_psi_c)  # s_0 − s_c
    contact_excess = np.maximum(drop, 0.0) + release_excess  # ω_C² / (4γ)
    m_0 = s_0 + release_excess
    one_minus_m0 = c_0 - release_excess

    # Fall: below the top (m0 < 1) both ends are timed from the turning point; above it the
    # modulus is inverted and the amplitude is ψ/2 itself.
    libration = one_minus_m0 > 0.0
    m_lib = np.where(libration, m_0, 0.5)
    q_lib = np.where(libration, one_minus_m0, 0.5)
    fall_libration = (_phase_from_turning_point(contact_excess, s_c, c_c, m_lib, q_lib)
                      - _phase_from_turning_point(release_excess, s_0, c_0, m_lib, q_lib))
    m_rot = np.where(libration, 1.0, m_0)
    fall_rotation = ((_phase_over_the_top(half_psi_0, release_excess, c_0, m_rot)
                      - _phase_over_the_top(half_psi_c, contact_excess, c_c, m_rot))
                     / np.sqrt(m_rot))
    t_c = np.where(libration, fall_libration, fall_rotation) / root_gamma
    omega_c = 2.0 * root_gamma * np.sqrt(contact_excess)

    # Flights k = 0 … N; k = 0 (full contact speed) is t_B, the N = 0 term of eq. 11.
    k = np.arange(n_flights + 1)
    excess = contact_excess[:, None] * safe_alpha(r.alpha, reason)[:, None] ** (2 * k)
    m_k = s_c[:, None] + excess
    returns = c_c[:, None] - excess > 0.0  # m_k < 1
    m_safe = np.where(returns, m_k, 0.5)
    sin2_chi = np.clip(excess / (m_safe * c_c[:, None]), 0.0, 1.0)
    phase = ellipkinc(np.arcsin(np.sqrt(sin2_chi)), m_safe)
    all_flights = np.where(returns, 2.0 * phase / root_gamma[:, None], np.inf)
    reason = np.where((reason == OK) & ~returns[:, 1:].all(axis=1), np.int8(OVER_THE_TOP),
                      reason)
    return masked_bounces(reason, alpha=r.alpha, flights=all_flights[:, 1:], t_c=t_c,
                          t_b=all_flights[:, 0], theta_c=theta_c, omega_c=omega_c,
                          tip_speed_c=omega_c * r.arm)
