"""The exact pendulum: θ̈ = γ cos θ between impacts, solved in closed form.

With ψ = π/2 − θ (the angle from the hanging vertical) the motion is a plain pendulum,
ψ̈ = −γ sin ψ, whose energy m = sin²(ψ/2) + ψ̇²/(4γ) is conserved between impacts. Every time
of travel is then an incomplete elliptic integral of the first kind, F(φ | m) (parameter
m = k²; scipy's ``ellipkinc``, evaluated here in Carlson's form with ``elliprf``). This is the
paper's eq. 5, generalised to a release angle and speed, and exact: no ODE is integrated.

Numerically, every time is measured from the turning point through the complementary
amplitude, K(m) − F(φ | m) = F(χ | m) with sin²χ = e / (m (1 − s)), where s = sin²(ψ/2) and
e = m − s = ψ̇²/(4γ) is the kinetic "excess" at that angle. The excesses, s, 1 − s and 1 − m are
carried separately (s − s' = sin(ψ/2 − ψ'/2) sin(ψ/2 + ψ'/2)), never recovered by subtracting
nearly equal numbers, so a tiny release speed, a release close to upright and the slow, late
flights all keep full precision. The fall uses Carlson's symmetric form,
F(χ | m) = √e R_F(s(1 − m), m(1 − m), m(1 − s)), which stays accurate as m → 1; each flight is
one ``elliprf`` call.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from scipy.special import elliprf

from drumroll.physics.bounces import (
    OK,
    OVER_THE_TOP,
    RELEASED_BELOW_CONTACT,
    Bounces,
    masked_bounces,
)
from drumroll.physics.geometry import StickGeometry
from drumroll.physics.model import ForwardModel, Values, alpha_of, alpha_valid
from drumroll.physics.release import passes, prepare_release, swing
from drumroll.physics.small_angle import PENDULUM_PARAMETERS


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


def contact(theta0: NDArray, theta_c: NDArray, omega0: NDArray, gamma: NDArray
            ) -> tuple[NDArray, ...]:
    """The fall's end points in the pendulum's energy variables.

    Returns
    -------
    half_psi_0, half_psi_c, s_0, c_0, s_c, c_c, release_excess, contact_excess
        ψ/2 = π/4 − θ/2 at release and at contact, s = sin²(ψ/2) and c = cos²(ψ/2) there, and
        the kinetic excesses ψ̇² / (4γ) at release and at contact (ω_C² / (4γ)).
    """
    half_psi_0 = 0.25 * np.pi - 0.5 * theta0
    half_psi_c = 0.25 * np.pi - 0.5 * theta_c
    s_0, c_0 = np.sin(half_psi_0) ** 2, np.cos(half_psi_0) ** 2
    s_c, c_c = np.sin(half_psi_c) ** 2, np.cos(half_psi_c) ** 2
    release_excess = omega0**2 / (4.0 * gamma)
    drop = np.sin(half_psi_0 - half_psi_c) * np.sin(half_psi_0 + half_psi_c)  # s_0 − s_c
    contact_excess = np.maximum(drop, 0.0) + release_excess  # ω_C² / (4γ)
    return half_psi_0, half_psi_c, s_0, c_0, s_c, c_c, release_excess, contact_excess


def flight_phase(excess: NDArray, m: NDArray, c_c: NDArray) -> NDArray:
    """F(χ | m) = K(m) − F(φ_C | m) of a flight leaving the head with kinetic excess
    ``excess`` (ψ̇²/(4γ)) at energy ``m``: sin²χ = excess / (m cos²(ψ_C/2)). T = 2 F / √γ."""
    sin2_chi = np.minimum(excess / (m * c_c), 1.0)
    # F(χ | m) = sin χ R_F(cos²χ, 1 − m sin²χ, 1): the same number (to 1e-15) as
    # ellipkinc(arcsin(sin χ), m) without the arcsine and at two thirds of its cost; this is
    # the sampler's innermost kernel.
    return np.sqrt(sin2_chi) * elliprf(1.0 - sin2_chi, 1.0 - m * sin2_chi, 1.0)


def flight_times(excess: NDArray, s_c: NDArray, c_c: NDArray, gamma: NDArray
                 ) -> tuple[NDArray, NDArray]:
    """Flights that leave the head with kinetic excess ``excess`` (ω_k² / (4γ), shape
    ``(batch, n)``): T = 2 F(χ | m) / √γ with m = s_C + excess, and where they return
    (m < 1; elsewhere the flight goes over the top and its time is a finite placeholder)."""
    returns = c_c[:, None] - excess > 0.0  # m < 1
    m = np.where(returns, s_c[:, None] + excess, 0.5)
    phase = flight_phase(np.where(returns, excess, 0.0), m, c_c[:, None])
    return 2.0 * phase / np.sqrt(gamma)[:, None], returns


class Pendulum(ForwardModel):
    """The exact pendulum in closed form (module docstring).

    t_C from the release (θ0, ω0) to θ_C, including a fall with m0 > 1 (enough energy to pass
    over the top); ω_C from energy conservation (eq. 4 when θ0 = ω0 = 0); flights
    T_k = 2 F(χ_k | m_k) / √γ with m_k = s_C + r_k² (m0 − s_C), r_k = α^k under a constant
    restitution (:mod:`drumroll.physics.restitution`). A point where a flight would
    have m_k ≥ 1 (over the top, never to return) is invalid; t_B is ``inf`` when only the
    fully elastic first rebound would pass over the top.
    """

    motion = "pendulum"
    motion_title = "exact pendulum"
    colours: ClassVar[dict[str, str]] = {"constant": "#0072B2", "speed": "#56B4E9"}
    motion_parameters = PENDULUM_PARAMETERS
    needs_stick = True

    def flights_at(self, ratios: NDArray, values: Values, stick_shape: str | None = None,
                   g: float = 9.81) -> tuple[NDArray, NDArray]:
        alpha, theta0 = alpha_of(values), values["release_angle"]
        checks, (gamma, _, sin_theta_c, omega0) = swing(
            stick_shape, values["stick_length"], values["stick_tip"], values["stick_radius"],
            values["pivot"], values["height"], values["release_speed"], theta0, g)
        if np.ndim(gamma) == 0:  # every geometric parameter fixed
            gamma, sin_theta_c, omega0 = (np.full(alpha.shape, v)
                                          for v in (gamma, sin_theta_c, omega0))
        with np.errstate(all="ignore"):
            theta_c = np.arcsin(sin_theta_c)
            valid = passes(checks, np.isfinite(alpha) & alpha_valid(alpha) & (theta0 < theta_c))
            *_, s_c, c_c, _, contact_excess = contact(theta0, theta_c, omega0, gamma)
            excess = contact_excess[:, None] * ratios**2
            if ratios.shape[1]:  # r_k ≤ 1 falls: the first flight rises highest, so it alone
                # can go over the top
                valid &= c_c - excess[:, 0] > 0.0
            phase = flight_phase(excess, s_c[:, None] + excess, c_c[:, None])
            return phase * (2.0 / np.sqrt(gamma))[:, None], valid

    def height_ratio(self, theta_c: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        # Exact geometry: sin θ_C = h / (L − d).
        return np.sin(theta_c), np.cos(theta_c), (theta_c > 0.0) & (theta_c < 0.5 * np.pi)

    def contact_angle(self, ratio: NDArray) -> NDArray:
        return np.arcsin(ratio)

    def bounces_at(self, values: dict[str, NDArray], ratios: NDArray, n_flights: int,
                   stick: StickGeometry | None = None, g: float = 9.81) -> Bounces:
        r = prepare_release(values["alpha"], values["pivot"], values["height"], stick,
                            values["release_speed"], values["release_angle"], g)
        theta_c = np.arcsin(r.sin_theta_c)
        reason = np.where((r.reason == OK) & ~(r.theta0 < theta_c),
                          np.int8(RELEASED_BELOW_CONTACT), r.reason)
        root_gamma = np.sqrt(r.gamma)
        (half_psi_0, half_psi_c, s_0, c_0, s_c, c_c, release_excess,
         contact_excess) = contact(r.theta0, theta_c, r.omega0, r.gamma)
        m_0 = s_0 + release_excess
        one_minus_m0 = c_0 - release_excess

        # Fall: below the top (m0 < 1) both ends are timed from the turning point; above it
        # the modulus is inverted and the amplitude is ψ/2 itself.
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

        # Flights k = 0 … N; k = 0 (full contact speed, r_0 = 1) is t_B, the N = 0 term of
        # eq. 11.
        all_ratios = np.concatenate([np.ones((ratios.shape[0], 1)), ratios], axis=1)
        excess = contact_excess[:, None] * all_ratios**2
        times, returns = flight_times(excess, s_c, c_c, r.gamma)
        all_flights = np.where(returns, times, np.inf)
        reason = np.where((reason == OK) & ~returns[:, 1:].all(axis=1),
                          np.int8(OVER_THE_TOP), reason)
        return masked_bounces(reason, alpha=r.alpha, flights=all_flights[:, 1:],
                              speed_ratios=ratios, t_c=t_c,
                              t_b=all_flights[:, 0], theta_c=theta_c, omega_c=omega_c,
                              tip_speed_c=omega_c * r.arm)
