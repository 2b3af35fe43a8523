"""The small-angle pendulum (eqs. 6–7, 10–11): constant angular acceleration γ.

Linearising sin θ ≈ θ and cos θ ≈ 1 makes every flight a parabola in θ(t), so the flights are
exactly geometric, T_k = 2 r_k ω_C / γ (r_k = α^k under a constant restitution), and h, d and
the release speed enter only through ω_C / γ (docs/physics.md).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from drumroll.physics.bounces import RELEASED_BELOW_CONTACT, Bounces, masked_bounces
from drumroll.physics.geometry import StickGeometry
from drumroll.physics.model import ForwardModel, Values, alpha_of, alpha_valid, geometric
from drumroll.physics.release import passes, prepare_release, swing

#: The pendulum models' parameters (SI), besides the stick.
PENDULUM_PARAMETERS = ("alpha", "pivot", "height", "release_speed", "release_angle")


def contact_speed(gamma: NDArray, theta_c: NDArray, theta0: NDArray, omega0: NDArray
                  ) -> NDArray:
    """ω_C = sqrt(ω0² + 2γ(θ_C − θ0)) (eq. 7 with a release speed): the linearised fall."""
    return np.sqrt(omega0**2 + 2.0 * gamma * np.maximum(theta_c - theta0, 0.0))


class SmallAngle(ForwardModel):
    """The linearised pendulum: θ_C ≈ h / (L − d), ω_C = sqrt(ω0² + 2γ(θ_C − θ0)),
    t_C = (ω_C − ω0)/γ (eq. 7 when ω0 = θ0 = 0) and T_k = 2 α^k ω_C / γ (eq. 11 with
    t_B = 2 ω_C / γ)."""

    motion = "small-angle"
    motion_title = "small-angle pendulum"
    colours: ClassVar[dict[str, str]] = {"constant": "#D55E00", "speed": "#E69F00"}
    linestyle = (0, (5, 2))
    motion_parameters = PENDULUM_PARAMETERS
    needs_stick = True
    geometric_flights = True

    def flights_at(self, ratios: NDArray, values: Values, stick_shape: str | None = None,
                   g: float = 9.81) -> tuple[NDArray, NDArray]:
        alpha, theta0 = alpha_of(values), values["release_angle"]
        checks, (gamma, _, theta_c, omega0) = swing(
            stick_shape, values["stick_length"], values["stick_tip"], values["stick_radius"],
            values["pivot"], values["height"], values["release_speed"], theta0, g)
        with np.errstate(all="ignore"):
            valid = passes(checks, np.isfinite(alpha) & alpha_valid(alpha) & (theta0 < theta_c))
            t_b = 2.0 * contact_speed(gamma, theta_c, theta0, omega0) / gamma
            if np.ndim(t_b) == 0:  # every geometric parameter fixed
                t_b = np.full(alpha.shape, t_b)
            return geometric(t_b, ratios), valid

    def height_ratio(self, theta_c: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        # Linearised geometry (eq. 6): θ_C = h / (L − d).
        return theta_c, np.ones_like(theta_c), theta_c > 0.0

    def contact_angle(self, ratio: NDArray) -> NDArray:
        return ratio

    def bounces_at(self, values: dict[str, NDArray], ratios: NDArray, n_flights: int,
                   stick: StickGeometry | None = None, g: float = 9.81) -> Bounces:
        r = prepare_release(values["alpha"], values["pivot"], values["height"], stick,
                            values["release_speed"], values["release_angle"], g)
        theta_c = r.sin_theta_c  # linearised contact angle h / (L − d)
        reason = np.where((r.reason == 0) & ~(r.theta0 < theta_c),
                          np.int8(RELEASED_BELOW_CONTACT), r.reason)
        omega_c = contact_speed(r.gamma, theta_c, r.theta0, r.omega0)
        t_b = 2.0 * omega_c / r.gamma
        return masked_bounces(reason, alpha=r.alpha, flights=geometric(t_b, ratios),
                              speed_ratios=ratios, t_c=(omega_c - r.omega0) / r.gamma, t_b=t_b,
                              theta_c=theta_c, omega_c=omega_c, tip_speed_c=omega_c * r.arm)
